#include "tools/basis_command.h"

#include <Eigen/Core>
#include <boost/program_options.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "core/memory/view_basis.h"
#include "settings/settings.h"
#include "tools/command_line.h"
#include "tools/eval.h"
#include "tools/frame_view.h"

namespace tsc {
namespace {

namespace fs = std::filesystem;
namespace po = boost::program_options;

constexpr const char* kBasisHelp =
    R"(usage: tsc basis --out FILE [--dimension K] [--every N] [--check DIR]... DIR...

Fits the principal basis member views are kept in (memory.view_basis; docs/decisions.md "A
principal basis for member views"): the K principal axes of the descriptors of every N-th
frame of the datasets DIR..., with the configuration's features. Writes them to FILE in the
form tscd compiles in (core/memory/data/). For each dataset, fitted or --check, it prints what
the basis keeps: the share of the energy of the descriptors, of the steps between consecutive
base points, and how often a base point's nearest other one (5 or more base points away) is
the same in the basis as in the descriptors.

Options)";

// Every frame's descriptor (dim x frames).
Eigen::MatrixXf Describe(const fs::path& dir, const Settings& settings) {
  const Dataset dataset = Dataset::Open(dir, DatasetOptionsOf(settings));
  const PipelineOptions& o = settings.pipeline;
  BubbleSurface surface(o.features, dataset.camera(), o.surface);
  const DescriptorComputer computer(surface.grid(), o.descriptor);
  Eigen::MatrixXf out;
  for (int i = 0; i < dataset.size(); ++i) {
    const Descriptor d = DescribeFrame(dataset, i, surface, computer).view.descriptor;
    if (i == 0) out.resize(d.dim(), dataset.size());
    out.col(i) = d.values();
  }
  return out;
}

// Index of each column's nearest other column at least `gap` columns away (−1 when none).
std::vector<int> NearestApart(const Eigen::MatrixXf& x, int gap) {
  const Eigen::VectorXf norms = x.colwise().squaredNorm().transpose();
  const Eigen::MatrixXf gram = x.transpose() * x;
  std::vector<int> nearest(static_cast<size_t>(x.cols()), -1);
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    float best = 0;
    for (Eigen::Index j = 0; j < x.cols(); ++j) {
      if (std::abs(i - j) < gap) continue;
      const float d = norms(i) + norms(j) - 2 * gram(i, j);
      if (nearest[static_cast<size_t>(i)] < 0 || d < best) {
        best = d;
        nearest[static_cast<size_t>(i)] = static_cast<int>(j);
      }
    }
  }
  return nearest;
}

void Report(const std::string& what, const Eigen::MatrixXf& x, const Eigen::MatrixXf& axes) {
  const Eigen::MatrixXf centred = x.colwise() - x.rowwise().mean();
  const Eigen::MatrixXf y = axes * x;
  const double energy = (axes * centred).squaredNorm() / centred.squaredNorm();
  const Eigen::MatrixXf steps = x.rightCols(x.cols() - 1) - x.leftCols(x.cols() - 1);
  const double step_energy = (axes * steps).squaredNorm() / steps.squaredNorm();
  const std::vector<int> a = NearestApart(x, 5), b = NearestApart(y, 5);
  int same = 0, counted = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i] < 0) continue;
    ++counted;
    same += a[i] == b[i];
  }
  std::printf("  %-40s %5lld base points: energy %.4f, steps %.4f, nearest kept %.4f\n",
              what.c_str(), static_cast<long long>(x.cols()), energy, step_energy,
              counted ? static_cast<double>(same) / counted : 1.0);
}

int Basis(const std::vector<std::string>& args) {
  po::options_description desc(kBasisHelp);
  desc.add_options()("help,h", "show this help")(
      "out", po::value<std::string>()->value_name("FILE"), "basis file to write")(
      "dimension", po::value<int>()->default_value(128)->value_name("K"), "axes kept")(
      "every", po::value<int>()->default_value(3)->value_name("N"), "fit on every N-th frame")(
      "check", po::value<std::vector<std::string>>()->composing()->value_name("DIR"),
      "a dataset the basis is not fitted on, to report (repeatable)");
  AddConfigOptions(desc);
  po::options_description hidden;
  hidden.add_options()("datasets", po::value<std::vector<std::string>>(), "DIR...");
  po::options_description all;
  all.add(desc).add(hidden);
  po::positional_options_description positional;
  positional.add("datasets", -1);
  const po::variables_map vm = ParseCommandLine(args, all, &positional);
  if (vm.count("help")) {
    std::cout << desc << "\n";
    return kExitOk;
  }
  const std::vector<std::string> dirs = vm.count("datasets")
                                            ? vm["datasets"].as<std::vector<std::string>>()
                                            : std::vector<std::string>{};
  if (dirs.empty()) throw UsageError("no dataset to fit on");
  if (!vm.count("out")) throw UsageError("--out FILE is required");
  const int k = vm["dimension"].as<int>(), every = vm["every"].as<int>();
  if (every < 1) throw UsageError("--every must be at least 1");
  // The basis is fitted on descriptors, so none may be configured for describing them.
  const Settings settings = SettingsFromCommandLine(vm, {"memory.view_basis=none"});

  std::vector<Eigen::MatrixXf> described;
  Eigen::Index dim = 0, fit_columns = 0;
  for (const std::string& dir : dirs) {
    described.push_back(Describe(dir, settings));
    if (dim != 0 && described.back().rows() != dim)
      throw std::runtime_error(dir + ": other dimension");
    dim = described.back().rows();
    fit_columns += (described.back().cols() + every - 1) / every;
  }
  Eigen::MatrixXf fit(dim, fit_columns);
  Eigen::Index c = 0;
  for (const Eigen::MatrixXf& x : described) {
    for (Eigen::Index i = 0; i < x.cols(); i += every) fit.col(c++) = x.col(i);
  }
  double retained = 0;
  const Eigen::MatrixXf axes = PrincipalAxes(fit, k, &retained);
  const std::vector<uint8_t> bytes = ViewBasisBytes(axes);
  const fs::path out = vm["out"].as<std::string>();
  {
    std::ofstream file(out, std::ios::binary | std::ios::trunc);
    file.write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
    file.close();
    if (!file) throw std::runtime_error(out.string() + ": write failed");
  }
  const ViewBasis basis = ParseViewBasis(bytes, out.string());
  std::printf(
      "tsc basis: %d axes of %lld dimensions from %lld base points of %zu datasets keep "
      "%.4f of their variance; id %016llx, written to %s\n",
      k, static_cast<long long>(dim), static_cast<long long>(fit_columns), dirs.size(), retained,
      static_cast<unsigned long long>(basis.id()), out.string().c_str());
  std::printf("fitted on:\n");
  for (size_t i = 0; i < dirs.size(); ++i) Report(dirs[i], described[i], axes);
  if (vm.count("check")) {
    std::printf("not fitted on:\n");
    for (const std::string& dir : vm["check"].as<std::vector<std::string>>()) {
      Report(dir, Describe(dir, settings), axes);
    }
  }
  return kExitOk;
}

}  // namespace

int RunBasisCommand(const std::vector<std::string>& args) {
  return RunReportingErrors("basis", [&] { return Basis(args); });
}

}  // namespace tsc
