#!/bin/sh
# The `gat` option conventions (tools/gat/cli_options.hpp): --opt=value,
# gat --version, gat help CMD, the same help on --help, and one line on stderr
# naming each missing or invalid argument (exit 2). Run by ctest
# (gat_cli_conventions) in the build directory: cli_conventions.sh GAT VERSION.
set -eu
g=$1
version=$2
fail() { echo "FAILED: $*"; exit 1; }

$g --version > v.txt
grep -q "^gat (gatcore) $version, git " v.txt || fail "--version: $(cat v.txt)"
grep -q 'CPU kernels: SIMD ' v.txt || fail "--version has no SIMD level"
grep -q '^Vulkan' v.txt || fail "--version says nothing about Vulkan"
$g help | grep -q 'predict-weights' || fail "gat help lists no commands"
$g help deform | grep -q 'Usage: gat deform' || fail "gat help deform"
$g dataset build --help | grep -q 'Usage: gat dataset build' || fail "gat dataset build --help"
$g help dataset build | grep -q 'Usage: gat dataset build' || fail "gat help dataset build"
[ "$($g help train)" = "$($g train --help)" ] || fail "gat help train differs from gat train --help"
$g train --epochs=1 --samples=2 --out=gat_cli_eq.gcm --quiet > eq.txt || fail "--opt=value refused"
grep -q 'trained 1 epochs' eq.txt || fail "train --quiet printed no summary"
[ "$(wc -l < eq.txt)" = 2 ] || fail "train --quiet printed more than the summary: $(cat eq.txt)"

# check EXPECTED ARGS...: exit 2, one line on stderr containing EXPECTED.
check() {
  want=$1
  shift
  rc=0
  $g "$@" > out.txt 2> err.txt || rc=$?
  [ "$rc" = 2 ] || fail "gat $*: exit $rc, expected 2"
  [ "$(wc -l < err.txt)" = 1 ] || fail "gat $*: not one line: $(cat err.txt)"
  grep -qF -- "$want" err.txt || fail "gat $*: '$(cat err.txt)' does not say '$want'"
}
check 'gat deform: MOTION is required' deform m.gcm c.glb
check 'gat predict-weights: CHARACTER is required' predict-weights ns.gcm
check 'gat predict-weights: --out is required' predict-weights ns.gcm h5.glb
check 'gat errormap: --out is required' errormap h5.glb
check 'gat dataset build: --out is required' dataset build procedural:humanoid:0
check 'gat dataset build: CHARACTER is required' dataset build -o d.json
check 'gat dataset build: --validation: expects a number in [0, 0.9], got '"'"'half'"'" dataset build -o d.json --validation half x
check "gat eval: --seed: expects an integer in [0, 2147483647], got 'x'" eval --model m.gcm --seed x
check 'gat eval: --samples: expects an integer in [1, 1000000]' eval --model m.gcm --samples=-1
check 'gat eval: --poses: expects an integer' eval --model m.gcm --poses 1.5
check 'gat eval: --size: expects an integer' eval --model m.gcm --size big
check "gat train: --device: expects cpu, vulkan or auto, got 'gpu'" train --device gpu
check 'gat train: --epochs: 1 required' train --epochs
check 'frobnicate' frobnicate
check "gat help: unknown command 'frobnicate'" help frobnicate

# Out of memory is said in words with what was being done (1.5 GB of address
# space; a million tube samples need several).
# (Not under AddressSanitizer, GAT_SANITIZED=1: its shadow memory needs far
# more address space than any limit that makes the allocation fail.)
if [ "${GAT_SANITIZED:-0}" = 1 ]; then
  echo "out-of-memory check skipped under the sanitizers"
else
  rc=0
  (ulimit -v 1500000; $g eval --model gat_cli_eq.gcm --samples 1000000 > /dev/null 2> oom.txt) || rc=$?
  [ "$rc" = 1 ] || fail "eval out of memory: exit $rc"
  grep -q 'gat eval: .*out of memory.* while evaluating gat_cli_eq.gcm' oom.txt || fail "out of memory: $(cat oom.txt)"
fi
echo cli-ok
