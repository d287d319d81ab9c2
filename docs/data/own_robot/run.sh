#!/usr/bin/env bash
# A network for another robot than the contract's (docs/cli.md, "A network for your robot"): the robot
# of robot.toml (radius 0.2 m, wheels 0.5 m/s and 0.6 m/s^2, the 0.5 m wheel base), labelled, trained
# and exported with gpcnav alone, then compared with the GPC and the baselines on suite episodes
# made for that robot (make_files.py: the reference at half the suites' 0.4 m/s, the time limit doubled;
# seed 60, never used); then two on-policy rounds on other episodes (seed 62: the GPC driving with
# DART noise, then the first network driving) and the network trained again (m4.onnx).
# From the repository's root, the environment active; ~20 minutes on 2 cores.
set -euo pipefail
D=docs/data/own_robot
gpcnav dataset --out out/own_robot/data --samples 40000 --robot $D/robot.toml --preset improved --workers 1
gpcnav train out/own_robot/data --out out/own_robot/model --preset improved --layers 3 --hidden 64
gpcnav export out/own_robot/model --out $D/m3.onnx --passes 1
PYTHONPATH=. python $D/make_files.py encounters 40 60 - $D/robot.toml 0.5 out/own_robot/enc
PYTHONPATH=. python $D/make_files.py circle-crossing 40 60 5 $D/robot.toml 0.5 out/own_robot/cc5
gpcnav compare out/own_robot/enc/*.toml --controllers stand,blind,gpc,nn --model $D/m3.onnx --workers 2 \
    --out $D/COMPARE-encounters.json
gpcnav compare out/own_robot/cc5/*.toml --controllers stand,blind,gpc,nn --model $D/m3.onnx --workers 2 \
    --out $D/COMPARE-cc5.json
# two on-policy rounds on training episodes of another seed (62), the network trained again
PYTHONPATH=. python $D/make_files.py encounters 40 62 - $D/robot.toml 0.5 out/own_robot/train-enc
PYTHONPATH=. python $D/make_files.py circle-crossing 40 62 5 $D/robot.toml 0.5 out/own_robot/train-cc5
TRAIN="out/own_robot/train-enc/*.toml out/own_robot/train-cc5/*.toml"
gpcnav dataset --out out/own_robot/data --dagger gpc --round 1 --dagger-noise 0.05 --dagger-files $TRAIN \
    --preset improved --workers 1
gpcnav dataset --out out/own_robot/data --dagger $D/m3.onnx --round 2 --dagger-files $TRAIN --preset improved --workers 2
gpcnav train out/own_robot/data --out out/own_robot/model4 --preset improved --layers 3 --hidden 64
gpcnav export out/own_robot/model4 --out $D/m4.onnx --passes 1
for s in enc cc5; do
    gpcnav evaluate out/own_robot/$s/*.toml --controller nn --model $D/m4.onnx --workers 2 --out $D/EVAL-m4-$s.json
done
# once more on a seed nothing above ran (63)
PYTHONPATH=. python $D/make_files.py circle-crossing 40 63 5 $D/robot.toml 0.5 out/own_robot/cc5-s63
gpcnav compare out/own_robot/cc5-s63/*.toml --controllers stand,gpc,nn --model $D/m4.onnx --workers 2 \
    --out $D/COMPARE-cc5-seed63.json
