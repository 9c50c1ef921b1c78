# Sourced by scripts/demo, scripts/test and scripts/fuzz: the one configuration of each build
# tree, so that the scripts share its objects (the README's demo then test rebuilds nothing)
# and ccache serves every compile. Call after scripts/bootstrap: it installs ccache, and a
# configuration made before that would compile without it.

# Configures a build tree: `configure DIR [cmake arguments...]`. A new tree gets Ninja: it
# compiles a target's objects while the libraries it links are still being built, where Make
# waits for them. An existing tree keeps the generator it was made with.
configure() {
  local dir=$1
  shift
  local gen=()
  if [[ ! -f $dir/CMakeCache.txt ]] && command -v ninja >/dev/null; then gen=(-G Ninja); fi
  local launcher=()
  if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
  cmake -S . -B "$dir" "${gen[@]}" "${launcher[@]}" "$@"
}

# build/: warnings as errors. CI: line tables only (-g1): backtraces keep file and line, and
# the -O2 compile takes less CPU than with full debug info (docs/reliability.md, "CI time").
configure_build() {
  local flags=(-DTSCD_WERROR=ON)
  if [[ ${CI:-} == true ]]; then flags+=("-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG"); fi
  configure build "${flags[@]}"
}

# Sanitizer builds: -O1 (the sanitizers' usual level; compiles far faster than -O2 on the
# Eigen-heavy core), little debug info, assertions on. `configure_sanitizer address` makes
# build-asan (clang, ASan + UBSan, fuzz targets as libFuzzer binaries, the benchmarks too:
# their own set-up code runs nowhere else with assertions on); `configure_sanitizer thread`
# makes build-tsan (gcc, TSan).
configure_sanitizer() {
  local flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1")
  case "$1" in
    address) CXX=clang++ configure build-asan -DTSCD_SANITIZE=address -DTSCD_FUZZ=ON \
               -DTSCD_BUILD_BENCH=ON "${flags[@]}" ;;
    thread) configure build-tsan -DTSCD_SANITIZE=thread -DTSCD_BUILD_BENCH=OFF "${flags[@]}" ;;
    *) echo "configure_sanitizer: unknown sanitizer '$1'" >&2; return 2 ;;
  esac
}
