// Store's peer body cache (issue 23): the bodies of the peer memories merged last, by robot and
// digest, in the peer_bodies table (schema version 6). Opaque bytes here: the exchange encodes,
// decodes and checks them against their digests.

#include <limits>
#include <string>
#include <unordered_set>
#include <vector>

#include "store/sqlite_db.h"
#include "store/store.h"

namespace tsc {

using store_internal::Db;
using store_internal::Row;
using store_internal::Statement;
using store_internal::Transaction;

namespace {
constexpr int64_t kMaxRobot = std::numeric_limits<uint32_t>::max();
}  // namespace

std::map<uint32_t, std::vector<int64_t>> Store::LoadPeerBodyDigests() const {
  const Db db{db_, path_};
  std::map<uint32_t, std::vector<int64_t>> digests;
  Statement s(db, "SELECT robot, digest FROM peer_bodies ORDER BY robot, digest");
  while (s.Step()) {
    const Row row(db, s, "peer_bodies", "?");
    digests[static_cast<uint32_t>(row.Int(0, "robot", 1, kMaxRobot))].push_back(
        row.Int(1, "digest"));
  }
  return digests;
}

void Store::ForEachPeerBody(
    uint32_t robot, const std::function<void(int64_t, std::span<const unsigned char>)>& f) const {
  const Db db{db_, path_};
  Statement s(db, "SELECT digest, body FROM peer_bodies WHERE robot = ?1");
  s.Int(1, robot);
  while (s.Step()) {
    const Row row(db, s, "peer_bodies", "of robot " + std::to_string(robot));
    const int64_t digest = row.Int(0, "digest");
    row.Decode(1, "body", [&](store_internal::BlobReader& r) {
      const std::vector<unsigned char> bytes = r.TakeRest<unsigned char>();
      f(digest, bytes);
      return 0;
    });
  }
}

void Store::AddPeerBodies(uint32_t robot,
                          std::span<const std::pair<int64_t, std::vector<unsigned char>>> bodies) {
  const Db db{db_, path_};
  Transaction tx(db);
  Statement s(db, "INSERT OR REPLACE INTO peer_bodies(robot, digest, body) VALUES(?1, ?2, ?3)");
  for (const auto& [digest, bytes] : bodies) s.Int(1, robot).Int(2, digest).Blob(3, bytes).Run();
  tx.Commit();
}

std::unordered_set<int64_t> Store::KeepOnlyPeerBodies(uint32_t robot,
                                                      const std::unordered_set<int64_t>& named) {
  const Db db{db_, path_};
  Transaction tx(db);
  std::unordered_set<int64_t> kept;
  std::vector<int64_t> gone;
  {
    Statement s(db, "SELECT digest FROM peer_bodies WHERE robot = ?1");
    s.Int(1, robot);
    while (s.Step()) {
      const int64_t digest = Row(db, s, "peer_bodies", "?").Int(0, "digest");
      if (named.count(digest)) {
        kept.insert(digest);
      } else {
        gone.push_back(digest);
      }
    }
  }
  Statement drop(db, "DELETE FROM peer_bodies WHERE robot = ?1 AND digest = ?2");
  for (const int64_t digest : gone) drop.Int(1, robot).Int(2, digest).Run();
  tx.Commit();
  return kept;
}

}  // namespace tsc
