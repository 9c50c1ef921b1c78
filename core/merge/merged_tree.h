#pragma once
// The merged memory's tree (docs/decisions.md, "Merging"): single linkage
// (core/memory/single_linkage.h) over the SLINK trees of both memories and the cross links
// recognition measured between them. Inserting every added place into the base's SLINK would
// need γ to every earlier place, |added|·|places|·dim operations.

#include <vector>

#include "core/memory/learned_place.h"
#include "core/memory/slink.h"
#include "core/merge/merge_cases.h"
#include "core/merge/recognition.h"

namespace tsc {

/// The SLINK state over the merged `places` (the base's, then the added incoming places):
/// single linkage over the base's tree `base_tree`, the incoming tree `incoming_tree` with
/// each incoming place standing for the merged place that holds it (`merged_index`), and the
/// cross links to the nearest base places (`found`). Base places folded into another
/// (`holder`, per base place) leave `places`, their holder taking their links. `spheres` are
/// the merge's root spheres, needed only when places were added to a non-empty base. The base
/// tree as it is when nothing was added or folded.
Slink MergedTree(const Slink& base_tree, const Slink& incoming_tree,
                 const std::vector<int>& merged_index, const Recognitions& found,
                 const std::vector<int>& holder, const RootSpheres& spheres,
                 std::vector<LearnedPlace>& places);

}  // namespace tsc
