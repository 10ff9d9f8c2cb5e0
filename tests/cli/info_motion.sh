#!/bin/sh
# gat info on motions (docs/rig-conventions.md): the joint -> body part map
# the retargeter will use, --alias overriding it, a Frames: count that
# disagrees with the data read with a warning, ASF/AMC pairs, and a clear
# error for a clip a file does not have. Run by ctest (gat_info_motion):
# info_motion.sh GAT
set -eu
g=$1
fail() { echo "FAILED: $*"; exit 1; }
d=$(mktemp -d)
trap 'rm -rf "$d"' EXIT

# A joint-named (Biovision-style) BVH whose Frames: says 3 over 2 rows.
{
  printf 'HIERARCHY\r\nROOT Hips\r\n{\r\n\tOFFSET 0 100 0\r\n\tCHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation\r\n'
  printf '\tJOINT Chest\n\t{\n\t\tOFFSET 0 20 0\n\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n'
  printf '\t\tJOINT Chest2\n\t\t{\n\t\t\tOFFSET 0 22 0\n\t\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n'
  printf '\t\t\tJOINT Neck\n\t\t\t{\n\t\t\t\tOFFSET 0 8 0\n\t\t\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n'
  printf '\t\t\t\tJOINT Head\n\t\t\t\t{\n\t\t\t\t\tOFFSET 0 12 0\n\t\t\t\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n\t\t\t\t}\n\t\t\t}\n'
  for s in Left Right; do
    x=1; [ $s = Right ] && x=-1
    printf '\t\t\tJOINT %sCollar\n\t\t\t{\n\t\t\t\tOFFSET %s 0 0\n\t\t\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n' $s $((3 * x))
    printf '\t\t\t\tJOINT %sShoulder\n\t\t\t\t{\n\t\t\t\t\tOFFSET %s 3 0\n\t\t\t\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n' $s $((14 * x))
    printf '\t\t\t\t\tJOINT %sElbow\n\t\t\t\t\t{\n\t\t\t\t\t\tOFFSET %s 0 0\n\t\t\t\t\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n' $s $((28 * x))
    printf '\t\t\t\t\t\tJOINT %sWrist\n\t\t\t\t\t\t{\n\t\t\t\t\t\t\tOFFSET %s 0 0\n\t\t\t\t\t\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n\t\t\t\t\t\t}\n\t\t\t\t\t}\n\t\t\t\t}\n\t\t\t}\n' $s $((26 * x))
  done
  printf '\t\t}\n\t}\n'
  for s in Left Right; do
    x=1; [ $s = Right ] && x=-1
    printf '\tJOINT %sHip\n\t{\n\t\tOFFSET %s -5 0\n\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n' $s $((10 * x))
    printf '\t\tJOINT %sKnee\n\t\t{\n\t\t\tOFFSET 0 -43 0\n\t\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n' $s
    printf '\t\t\tJOINT %sAnkle\n\t\t\t{\n\t\t\t\tOFFSET 0 -44 0\n\t\t\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n' $s
    printf '\t\t\t\tJOINT %sToe\n\t\t\t\t{\n\t\t\t\t\tOFFSET 0 -6 13\n\t\t\t\t\tCHANNELS 3 Xrotation Yrotation Zrotation\n\t\t\t\t}\n\t\t\t}\n\t\t}\n\t}\n' $s
  done
  printf '}\nMOTION\nFrames: 3\nFrame Time: 0.0333333\n'
  for f in 1 2; do
    n=0; row='0 100 0 0 0 0'
    while [ $n -lt 20 ]; do row="$row 0 0 0"; n=$((n + 1)); done
    printf '%s \t\r\n' "$row"
  done
} > "$d/capture.bvh"

$g info "$d/capture.bvh" > out.txt 2> err.txt || fail "gat info capture.bvh: $(cat err.txt)"
grep -q 'Frames: says 3 but 2 frames' err.txt || fail "no frame-count warning: $(cat err.txt)"
grep -q '^convention Joint-named' out.txt || fail "convention: $(cat out.txt)"
grep -q '^read as    Y up, facing +Z' out.txt || fail "read as: $(cat out.txt)"
grep -q 'upperarm  LeftShoulder | RightShoulder' out.txt || fail "upper arms: $(cat out.txt)"
grep -q 'thigh     LeftHip | RightHip' out.txt || fail "thighs: $(cat out.txt)"
grep -q 'spine     Chest, Chest2' out.txt || fail "spine: $(cat out.txt)"
$g info "$d/capture.bvh" --alias Chest2=neck > alias.txt 2> /dev/null || fail "gat info --alias"
grep -q 'neck      Chest2, Neck' alias.txt || fail "--alias Chest2=neck: $(cat alias.txt)"
grep -q 'spine     Chest$' alias.txt || fail "--alias Chest2=neck left the spine: $(cat alias.txt)"

# ASF/AMC: skeleton beside the motion, and named explicitly.
cat > "$d/07.asf" <<'ASF'
:version 1.10
:name VICON
:units
  mass 1.0
  length 0.45
  angle deg
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name lfemur
     direction 0 -1 0
     length 7.5
     axis 0 0 20 XYZ
     dof rx ry rz
     limits (-160.0 20.0)
            (-70.0 70.0)
            (-60.0 70.0)
  end
:hierarchy
  begin
    root lfemur
  end
ASF
printf ':FULLY-SPECIFIED\n:DEGREES\n1\nroot 0 17 0 0 0 0\nlfemur 10 0 -5\n2\nroot 0 17 1 0 0 0\n' > "$d/07_05.amc"
$g info "$d/07_05.amc" > amc.txt 2>&1 || fail "gat info 07_05.amc: $(cat amc.txt)"
grep -q '07_05.amc *2 frames at 120 fps' amc.txt || fail "amc: $(cat amc.txt)"
$g info "$d/07.asf:$d/07_05.amc" > amc2.txt 2>&1 || fail "gat info 07.asf:07_05.amc: $(cat amc2.txt)"
rc=0
$g info "$d/07.asf" > bad.txt 2>&1 || rc=$?
[ "$rc" != 0 ] && grep -q 'holds a skeleton, not a motion' bad.txt || fail "a lone .asf: $(cat bad.txt)"
echo info-motion-ok
