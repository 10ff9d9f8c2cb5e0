"""A gatcore checkpoint re-saved by Python's safetensors still loads.

Usage: resave_checkpoint.py TEST_CHECKPOINT_EXE WORK_DIR
1. the test executable writes a resumable checkpoint ([.python-write]);
2. safetensors.numpy.save_file(load_file(x), metadata=<x's metadata>) writes
   it again (Python's own layout: tensors sorted, other offsets) -- the same
   code path as safetensors.torch.save_file, without needing torch;
3. the test executable loads the re-saved file, compares every tensor and
   resumes from it ([.python-read]).
Exits 77 (ctest: skipped) when the safetensors package is not installed.
"""
import json
import os
import struct
import subprocess
import sys

try:
    from safetensors.numpy import load_file, save_file
except ImportError as e:
    print(f"SKIPPED: the Python safetensors package is not installed ({e}); "
          "scripts/test.sh installs it into build/pyvenv", flush=True)
    sys.exit(77)

exe, work = sys.argv[1], sys.argv[2]
os.makedirs(work, exist_ok=True)
src = os.path.join(work, "python_src.gcm")
dst = os.path.join(work, "python_resaved.gcm")
env = dict(os.environ, GATCORE_CKPT=src, GATCORE_CKPT_RESAVED=dst)
subprocess.run([exe, "[.python-write]"], env=env, check=True)

with open(src, "rb") as f:
    n = struct.unpack("<Q", f.read(8))[0]
    metadata = json.loads(f.read(n))["__metadata__"]
save_file(load_file(src), dst, metadata=metadata)
print(f"re-saved {src} -> {dst} with safetensors (python)", flush=True)

sys.exit(subprocess.run([exe, "[.python-read]"], env=env).returncode)
