#!/usr/bin/env bash
# The robustness rule "every item has a test that failed before the fix", checked
# again for the fixes that can be taken out in place (docs/robustness.md has
# the rest and the full record). For each entry below: take the fix out of
# the source (one exact text replacement), rebuild the test, run it and
# EXPECT IT TO FAIL; put the source back, rebuild, and expect it to pass.
# A replacement that no longer matches the source is reported as STALE (the
# fix moved: update the entry), never as a pass.
# Usage: bash scripts/check_fixes_fail_without.sh [BUILD_DIR] [NAME_FILTER]
#   BUILD_DIR: a configured build (default build/); NAME_FILTER: a grep -E
#   pattern over the entry names (default: all). Never run two at once.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="${1:-build}"
only="${2:-.}"
[[ -f "$build/CMakeCache.txt" ]] || { echo "check_fixes: $build is not a configured build folder" >&2; exit 2; }
backup="$(mktemp -d)"
failures=0
current=""
# Whatever happens, the source goes back.
restore() { [[ -n "$current" ]] && cp "$backup/saved" "$current" && current=""; return 0; }
trap 'restore; rm -rf "$backup"' EXIT INT TERM

# One test binary, bounded in time and memory (without a fix, a test can
# ask for tens of GB: the .pc2 reproducers did), failing when its filter
# selects no test (Catch2: only a leading or trailing '*', commas separate).
run_test() {
  local target="$1"
  shift
  (ulimit -v 8000000; exec timeout 300 "$build/tests/$target" -w NoTests "$@")
}

# check NAME TARGET FILE TEST_ARGS... < OLD\n===\nNEW
check() {
  local name="$1" target="$2" file="$3"
  shift 3
  local edit
  edit="$(cat)"
  grep -qE -- "$only" <<<"$name" || return 0
  if ! git diff --quiet -- "$file"; then
    echo "SKIP  $name: $file has uncommitted changes"
    return 0
  fi
  cp "$file" "$backup/saved"
  current="$file"
  printf '%s\n' "$edit" >"$backup/edit"
  if ! python3 - "$file" "$backup/edit" <<'PY'
import sys
path, edit = sys.argv[1], sys.argv[2]
old, new = (open(edit).read() + "\n").split("\n===\n")
src = open(path).read()
if src.count(old) != 1:
    sys.exit(1)
open(path, "w").write(src.replace(old, new.rstrip("\n")))
PY
  then
    restore
    echo "STALE $name: the fix's text is no longer in $file"
    failures=$((failures + 1))
    return 0
  fi
  local without="passed" with="failed"
  if cmake --build "$build" -j2 --target "$target" >"$backup/log" 2>&1; then
    run_test "$target" "$@" >"$backup/log" 2>&1 || without="failed"
  else
    without="did not build"
  fi
  restore
  cmake --build "$build" -j2 --target "$target" >/dev/null 2>&1 &&
    run_test "$target" "$@" >/dev/null 2>&1 && with="passed"
  if [[ "$without" == "failed" && "$with" == "passed" ]]; then
    echo "ok    $name: $target fails without the fix, passes with it"
  else
    echo "BAD   $name: $target $without without the fix, $with with it"
    failures=$((failures + 1))
  fi
}

check item3_pc2_counts test_character_export src/character/io/bake.cpp \
  "bake and point cache errors leave no file behind" <<'EOF'
  GATCORE_CHECK(pc.num_points > 0 && n > 0, path, ": ", pc.num_points, " points x ", n,
                " samples (a point cache needs at least one of each)");
  GATCORE_CHECK(std::isfinite(pc.start_frame) && std::isfinite(pc.sample_rate) && pc.sample_rate > 0.0f, path,
                ": bad start frame ", pc.start_frame, " or sample rate ", pc.sample_rate);
  const std::uint64_t payload = b.size() - kHeader, per_sample = 12ull * std::uint64_t(pc.num_points);
  GATCORE_CHECK(payload % per_sample == 0 && payload / per_sample == std::uint64_t(n), path, ": ", b.size(),
===
  GATCORE_CHECK(pc.num_points >= 0 && n >= 0, path, ": negative point or sample count");
  const std::uint64_t per_sample = 12ull * std::uint64_t(pc.num_points);
  GATCORE_CHECK(b.size() == kHeader + per_sample * std::uint64_t(n), path, ": ", b.size(),
EOF

check item4_tensor_shape_product test_tensor src/tensor.cpp "tensor: construction errors" <<'EOF'
  GATCORE_CHECK(cols == 0 || rows <= kMaxElems / cols, what, ": shape [", rows, ", ", cols,
===
  GATCORE_CHECK(true, what, ": shape [", rows, ", ", cols,
EOF

check item4_checkpoint_shape_vs_offsets test_checkpoint src/models/checkpoint.cpp \
  "bad checkpoint files are rejected with messages naming the file and the problem" <<'EOF'
    if ((*e - *b) % sizeof(float) != 0 || (*c == 0 ? elems != 0 : (*r > elems / *c || *r * *c != elems)))
===
    if (false)
EOF

check item8_checksum_covers_header test_checkpoint src/models/checkpoint.cpp \
  "bad checkpoint files are rejected with messages naming the file and the problem" <<'EOF'
    if (k != "checksum") h.add_str(k), h.add_str(v);
===
    (void)k, (void)v;
EOF

check item8_strict_metadata_numbers test_checkpoint src/models/checkpoint.cpp \
  "checkpoint metadata is validated*" <<'EOF'
  const std::string& s = it->second;
  char* end = nullptr;
===
  const std::string& s = it->second;
  if (lo <= hi) return std::stod(s);
  char* end = nullptr;
EOF

check item2_5_dataset_ranges test_character_dataset src/character/data/dataset_io.cpp \
  "dataset files are validated like gat dataset build's options (the shared reproducers)" <<'EOF'
  GATCORE_CHECK(j.is_number(), path, ": field \"", field, "\" must be a number, got ", j.dump());
===
  if (lo <= hi) return j.get<T>();
  GATCORE_CHECK(j.is_number(), path, ": field \"", field, "\" must be a number, got ", j.dump());
EOF

check item9_bvh_frames_0 test_character_motion src/character/io/bvh.cpp \
  "BVH import: the fuzzing shared reproducers end in a clear error" <<'EOF'
  if (frames == 0) lx.fail("Frames: 0 (the motion has no frames)");
===
EOF

check item9_bvh_frame_time test_character_motion src/character/io/bvh.cpp \
  "BVH import: the fuzzing shared reproducers end in a clear error" <<'EOF'
  if (!(frame_time > 0.0) || !std::isfinite(1.0 / frame_time))
===
  if (false)
EOF

check item9_bvh_finite_numbers test_character_motion src/character/io/bvh.cpp \
  "BVH import: the fuzzing shared reproducers end in a clear error" <<'EOF'
    if (!std::isfinite(v) || std::abs(v) > 1e30) fail(detail::cat(what(), ": '", t, "' is not a finite number"));
===
EOF

check item1_bvh_not_to_assimp test_character_assimp src/character/io/assimp_import.cpp \
  "FBX import rejects bad files" <<'EOF'
    GATCORE_CHECK(ext != ".bvh", path, ": a BVH file holds a motion, not a character (read it with load_bvh)");
===
EOF

check item1_assimp_in_child test_character_assimp src/character/io/assimp_import.cpp \
  "assimp parses a user's file in a child process*" <<'EOF'
  probe_in_child(path);
  Assimp::Importer imp;
===
  Assimp::Importer imp;
EOF

check item7_gltf_written_atomically test_atomic_write src/character/io/gltf_util.cpp \
  "*writers fail cleanly on a full disk" <<'EOF'
  write_file_atomic(path, os.str());
===
  if (std::FILE* f = std::fopen(path.c_str(), "wb")) std::fwrite(os.str().data(), 1, os.str().size(), f), std::fclose(f);
EOF

check item13_dataset_written_atomically test_atomic_write src/character/data/dataset_io.cpp \
  "*writers fail cleanly on a full disk" <<'EOF'
  write_file_atomic(path, j.dump(2) + "\n");
===
  { std::ofstream(path + ".tmp") << j.dump(2) << "\n"; }
  std::filesystem::rename(path + ".tmp", path);
EOF

check item13_fsync_before_rename test_atomic_write src/atomic_file.cpp \
  "write_file_atomic: the data is on disk before the rename*" <<'EOF'
  if (::fsync(fd) != 0) abandon("fsync");
===
EOF

check item11_uri_confined test_character_gltf src/character/io/gltf.cpp \
  "glTF import reads external URIs only inside the model's folder" <<'EOF'
  gltf_util::confine_resources(loader, guard, path, opt.resource_root);
===
  (void)guard;
EOF

check item11_uri_confined_read_model test_character_gltf src/character/io/gltf_util.cpp \
  "glTF import reads external URIs only inside the model's folder" <<'EOF'
  confine_resources(gltf, guard, path);
===
  (void)guard;
EOF

check item12_singular_bind test_character_gltf src/character/io/gltf.cpp \
  "glTF import rejects bad files with the file and the problem" <<'EOF'
        if (!(std::abs(det) > 1e-12))
===
        if (false)
EOF

if [[ "$failures" -ne 0 ]]; then
  echo "check_fixes: $failures entries did not behave (see above)" >&2
  exit 1
fi
echo "check_fixes: every selected fix is needed by its test"
