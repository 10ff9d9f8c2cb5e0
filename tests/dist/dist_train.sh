#!/bin/sh
# Data-parallel `gat train` under mpirun against one process (CTest, tests/CMakeLists.txt).
#   dist_train.sh equivalence MODEL TOL   3 steps at 1, 2 and 4 ranks: checkpoints agree within TOL
#   dist_train.sh resume MODEL TOL        1 epoch at 2 ranks, resumed at 4 (and at 1): the 2-epoch one-process run
#   dist_train.sh killed                  rank 1 of 4 killed at step 4 (epoch 2): the job ends, non-zero, with a
#                                         message; the run continues from epoch 1's checkpoint
# Environment: GAT, DIFF (checkpoint_diff), MPIEXEC; oversubscribed (more ranks than cores: this measures
# correctness, not speed), one OpenMP thread per rank.
set -eu
mode=$1
: "${GAT:?}" "${DIFF:?}" "${MPIEXEC:?}"
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive
# CI runs as root; Open MPI refuses that unless told (harmless for other users).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mpi() { n=$1; shift; "$MPIEXEC" --oversubscribe --bind-to none -np "$n" "$@"; }
# 12 tube characters in batches of 4: 3 optimiser steps per epoch; 8 validate.
args="--samples 12 --batch 4 --sample-vertices 64 --seed 3"
case "$mode" in
  equivalence)
    model=$2 tol=$3
    rm -f dist_eq_"$model"_*.gcm
    "$GAT" train --model "$model" $args --epochs 1 --out dist_eq_"$model"_1.gcm > /dev/null
    for n in 2 4; do
      mpi "$n" "$GAT" train --model "$model" $args --epochs 1 --out dist_eq_"$model"_"$n".gcm > dist_eq_"$model"_"$n".log
      grep -q "$n MPI ranks (data parallel)" dist_eq_"$model"_"$n".log
      echo "$model: 1 process vs $n ranks:"
      "$DIFF" dist_eq_"$model"_1.gcm dist_eq_"$model"_"$n".gcm --tol "$tol"
    done
    # A fixed N is bit-reproducible.
    mpi 2 "$GAT" train --model "$model" $args --epochs 1 --out dist_eq_"$model"_2b.gcm > /dev/null
    echo "$model: 2 ranks, twice:"
    "$DIFF" dist_eq_"$model"_2.gcm dist_eq_"$model"_2b.gcm
    echo equivalence-ok ;;
  resume)
    model=$2 tol=$3
    rm -f dist_rs_"$model"_*.gcm
    "$GAT" train --model "$model" $args --epochs 2 --out dist_rs_"$model"_1.gcm > /dev/null
    mpi 2 "$GAT" train --model "$model" $args --epochs 1 --out dist_rs_"$model"_24.gcm > /dev/null
    cp dist_rs_"$model"_24.gcm dist_rs_"$model"_21.gcm
    mpi 4 "$GAT" train --resume dist_rs_"$model"_24.gcm --epochs 2 --out dist_rs_"$model"_24.gcm > /dev/null
    "$GAT" train --resume dist_rs_"$model"_21.gcm --epochs 2 --out dist_rs_"$model"_21.gcm > /dev/null
    echo "$model: 2 epochs in one process vs 1 epoch at 2 ranks + 1 at 4:"
    "$DIFF" dist_rs_"$model"_1.gcm dist_rs_"$model"_24.gcm --tol "$tol"
    echo "$model: ... vs 1 epoch at 2 ranks + 1 in one process:"
    "$DIFF" dist_rs_"$model"_1.gcm dist_rs_"$model"_21.gcm --tol "$tol"
    echo resume-ok ;;
  killed)
    rm -f dist_killed.gcm
    start=$(date +%s)
    set +e
    GAT_TRAIN_FAULT=1:4 timeout 120 "$MPIEXEC" --oversubscribe --bind-to none -np 4 -x GAT_TRAIN_FAULT \
      "$GAT" train --model neuroskinning $args --epochs 3 --out dist_killed.gcm > dist_killed.log 2>&1
    rc=$?
    set -e
    took=$(( $(date +%s) - start ))
    cat dist_killed.log
    echo "exit status $rc after $took s"
    test "$rc" -ne 0 && test "$rc" -ne 124
    grep -q "rank 1: GAT_TRAIN_FAULT" dist_killed.log
    # Open MPI's own report names the rank that died.
    grep -Eqi "rank 1 .*(exited|signal|killed)|process rank 1|exited on signal 9" dist_killed.log
    # Restart from the last checkpoint (epoch 1), at another N.
    grep -q "epoch 1/3" dist_killed.log
    mpi 2 "$GAT" train --resume dist_killed.gcm --epochs 2 --out dist_killed.gcm | grep -q "epoch 2/2"
    echo killed-ok ;;
  *) echo "unknown mode $mode"; exit 2 ;;
esac
