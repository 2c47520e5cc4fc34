#!/usr/bin/env bash
# Evaluates the students of research/train_multimodal.py (research/teacher_multimodal.md): held-out generated
# seeds of the canyon, mesa and fork families (10 seeds x 20 robots, one TOML per family), then canyon_left and its
# mirror image canyon_right (3 seeds x 20 robots). The categorical students are played three ways: acting by the
# mode (as trained), by "side" and by a seeded per-robot draw (copies of the file with another "acting").
#   flock /tmp/heavy.lock bash research/eval_multimodal.sh families      # then: ... canyons
# The second run (train_multimodal.py --recipe student, files acting by "sample"):
#   RUN=runs/multimodal2 OUT=runs/eval_multimodal2 TWINS="gru_fb gru_cat0 mlp_cat0" ACTINGS="mode side" \
#     MODELS=gru_fb=runs/multimodal2/gru_fb/policy,gru_fb_mode=runs/multimodal2/gru_fb_mode/policy,... \
#     flock /tmp/heavy.lock bash research/eval_multimodal.sh families
# POLICIES= (empty) leaves APF out (default: apf).
set -e
cd "$(dirname "$0")/.."
PY=${PY:-python}
RUN=${RUN:-runs/multimodal}
OUT=${OUT:-runs/eval_multimodal}
PART=${1:-families}
TWINS=${TWINS:-mlp_cat gru_cat}
ACTINGS=${ACTINGS:-side sample}
for v in $TWINS; do  # the twins of each categorical file acting otherwise (policies/heads.py)
  for acting in $ACTINGS; do
    $PY - "$RUN/$v/policy" "$RUN/${v}_$acting/policy" "$acting" <<'PY'
import json, shutil, sys
src, dst, acting = sys.argv[1:]
shutil.rmtree(dst, ignore_errors=True)
shutil.copytree(src, dst)
meta = json.load(open(f"{dst}/policy.json"))
meta["head"]["acting"] = acting
json.dump(meta, open(f"{dst}/policy.json", "w"), indent=1)
PY
  done
done
M=mlp_mse=$RUN/mlp_mse/policy
for v in mlp_cat gru_cat; do M="$M,$v=$RUN/$v/policy,${v}_side=$RUN/${v}_side/policy,${v}_s=$RUN/${v}_sample/policy"; done
MODELS=${MODELS:-$M}
if [ "$PART" = families ]; then
  mkdir -p "$OUT/cfg"
  scen=""
  for f in canyon mesa fork; do
    cat > "$OUT/cfg/gen_$f.toml" <<TOML
description = "generated terrains of the $f family only"
task = "goal"
max_cycles = 1000

[terrain]
source = "generated"
resample = "reset"
families = ["$f"]
method = "greedy"
max_error_m = 0.5

[robots]
count = 20
max_slope_deg = 30.0

[targets]
arrival_radius_m = 8.0
TOML
    scen="$scen${scen:+,}$OUT/cfg/gen_$f.toml"
  done
  $PY agents/evaluate.py --scenarios "$scen" --seeds 10 --robots 20 --policies "${POLICIES-apf}" --models "$MODELS" \
    --out "$OUT/families"
else
  $PY agents/evaluate.py --scenarios scenarios/canyon_left.toml,scenarios/canyon_right.toml --seeds 3 --robots 20 \
    --policies "${POLICIES-apf}" --models "$MODELS" --out "$OUT/canyons"
fi
