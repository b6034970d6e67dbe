#!/usr/bin/env bash
# Held-out-style / held-out-concept evaluation of the learned style metric on the dev set
# (issue 3 closing-note figures). Usage: scripts/metric/dev_eval.sh [FEATURES] [LABELS] [OUT]
# Needs a release build: cargo build --release -p learner --all-features
set -euo pipefail
FEATURES=${1:-.cache/dev-features.csv}
LABELS=${2:-.cache/style-data/dev/labels.csv}
OUT=${3:-/tmp/metric-dev}
BIN=${LEARNER:-${CARGO_TARGET_DIR:-target}/release/learner}
TEST_STYLES=${TEST_STYLES:-fluent-emoji-flat,emojione-monotone,icon-park}
mkdir -p "$OUT"
"$BIN" split --labels "$LABELS" --test-styles "$TEST_STYLES" --concept-fraction 0.3 --seed 0 \
  --train-out "$OUT/train-labels.csv" --test-out "$OUT/test-labels.csv"
"$BIN" triplets --labels "$OUT/train-labels.csv" --features "$FEATURES" --n 50000 --seed 1 --out "$OUT/train.csv"
"$BIN" triplets --labels "$OUT/test-labels.csv" --features "$FEATURES" --n 10000 --seed 2 --out "$OUT/test.csv"
"$BIN" train --features "$FEATURES" --triplets "$OUT/train.csv" --out "$OUT/model.json"
"$BIN" eval --model "$OUT/model.json" --features "$FEATURES" --triplets "$OUT/test.csv" --json "$OUT/eval.json"
"$BIN" rank --model "$OUT/model.json" --features "$FEATURES" --labels "$OUT/test-labels.csv" --json "$OUT/rank.json"
"$BIN" report --model "$OUT/model.json" --features "$FEATURES" --triplets "$OUT/train.csv" \
  --test "$OUT/test.csv" --out "$OUT/report"
