#!/bin/bash
# usage: run_case.sh DIR  (DIR holds ball_0000.rad / ball_0001.rad)
# OPENRADIOSS_PATH: the OpenRadioss source tree with its exec/ built (README.md)
: "${OPENRADIOSS_PATH:?set OPENRADIOSS_PATH}"
export RAD_CFG_PATH=$OPENRADIOSS_PATH/hm_cfg_files
export LD_LIBRARY_PATH=$OPENRADIOSS_PATH/exec:$OPENRADIOSS_PATH/extlib/h3d/lib/linux64:$LD_LIBRARY_PATH
export OMP_NUM_THREADS=1 KMP_STACKSIZE=400m
ulimit -s unlimited
here=$(cd "$(dirname "$0")" && pwd)
cd "$1" || exit 1
rm -f *.out *.rst ballT01* ballA0* *.csv
s0=$(date +%s.%N)
nice -n 19 $OPENRADIOSS_PATH/exec/starter_linux64_gf -i ball_0000.rad -np 1 -nt 1 > starter.log 2>&1
s1=$(date +%s.%N)
nice -n 19 $OPENRADIOSS_PATH/exec/engine_linux64_gf -i ball_0001.rad -nt 1 > engine.log 2>&1
s2=$(date +%s.%N)
echo "starter_s $(echo "$s1 - $s0" | bc) engine_s $(echo "$s2 - $s1" | bc)" > times.txt
"${TH_TO_CSV:?set TH_TO_CSV to OpenRadioss Tools th_to_csv}" ballT01 > th.log 2>&1
python3 "$here/post.py" . | tee result.txt
