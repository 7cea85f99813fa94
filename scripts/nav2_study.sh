#!/usr/bin/env bash
# The nav2 study of issue 58: exploration nodes (`madenet explore`, one process per robot)
# driving the simulated nav2 team (`madenet run --world continuous --nav2 --explore`) through
# ROS 2 alone, on generated floor plans, and the same trials in-process beside them.
#
#   scripts/nav2_study.sh OUT_DIR [MADENET_BIN]
#
# Nodes: explore_lite's shipped parameters (configs/explore_lite.yaml below), every method.
# Methods: (a) explore-lite-alone (explore_lite per robot on its own map, what users run),
# (b) explore-lite (teammates' maps merged), (c) spread, (d) made-net-any, (e) made-net. Each trial appends
# one JSON line to OUT_DIR/results.jsonl (or OUT_DIR/inprocess.jsonl) when it ends; a trial
# already there is skipped, so a killed study resumes where it stopped. Maps are generated
# into OUT_DIR/maps (floor plans, map seed 1000 + seed; never the paper's maps).
#
# Environment: SIZES ("20 40"), TEAMS ("2 3 4 6"), SEEDS (10), FIRST_SEED (1: two instances on
# seeds 1–5 and 6–10 share OUT_DIR, each line appended whole), METHODS, REALTIME (10),
# CAP_PER_CELL (6: the simulated-second cap is CAP_PER_CELL × size², ended by Ctrl-C).
# While OUT_DIR/PAUSE exists, no new trial starts (the one under way finishes): for a build or
# a test run that needs the machine.
set -euo pipefail
out=${1:?usage: scripts/nav2_study.sh OUT_DIR [MADENET_BIN]}
bin=${2:-target/release/madenet}
sizes=${SIZES:-"20 40"}
teams=${TEAMS:-"2 3 4 6"}
seeds=${SEEDS:-10}
first_seed=${FIRST_SEED:-1}
methods=${METHODS:-"explore-lite-alone explore-lite spread made-net-any made-net"}
realtime=${REALTIME:-10}
cap_per_cell=${CAP_PER_CELL:-6}
starts=(0,0 0,1 1,0 1,1 0,2 1,2)
mkdir -p "$out/maps" "$out/configs" "$out/logs"
touch "$out/results.jsonl" "$out/inprocess.jsonl"
# Every node runs with the parameters explore_lite ships (m-explore-ros2's
# explore/config/params.yaml, which its launch file loads): what its users run.
params="$out/configs/explore_lite.yaml"
cat > "$params" <<'YAML'
/**:
  ros__parameters:
    planner_frequency: 0.25
    progress_timeout: 30.0
    potential_scale: 3.0
    orientation_scale: 0.0
    gain_scale: 1.0
    transform_tolerance: 0.3
    min_frontier_size: 0.75
YAML

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

for size in $sizes; do
  for seed in $(seq "$first_seed" "$seeds"); do
    map="$out/maps/plan-$size-$seed.txt"
    [ -f "$map" ] || "$bin" map generate --floorplan --height "$size" --width "$size" \
      --seed $((1000 + seed)) --keep-free "$(IFS=';'; echo "${starts[*]}")" "$map" >/dev/null
    for team in $teams; do
      cfg="$out/configs/team-$team.toml"
      printf 'num_robots = %d\n' "$team" > "$cfg"
      start=$(IFS=';'; echo "${starts[*]:0:$team}")
      for method in $methods; do
        key="$size/$team/$seed/$method"
        policy=${method%-alone}
        # In-process: the same map, starts, team and seed (the paper's contact rule, CSP 1).
        while [ -e "$out/PAUSE" ]; do sleep 10; done
        if ! grep -qF "\"key\":\"$key\"" "$out/inprocess.jsonl" && [ "$method" != explore-lite-alone ]; then
          if res=$("$bin" run --world continuous --map "$map" --start "$start" --config "$cfg" \
              --seed "$seed" --policy "$policy" --json 2>>"$out/logs/inprocess.log"); then
            printf '{"key":"%s","size":%d,"team":%d,"seed":%d,"method":"%s","result":%s}\n' \
              "$key" "$size" "$team" "$seed" "$method" "$(tr -d '\n' <<<"$res")" >> "$out/inprocess.jsonl"
          fi
        fi
        grep -qF "\"key\":\"$key\"" "$out/results.jsonl" && continue
        while [ -e "$out/PAUSE" ]; do sleep 10; done
        alone=()
        [ "$method" = explore-lite-alone ] && alone=(--alone)
        cap=$(( cap_per_cell * size * size * 10 / realtime / 10 + 60 ))
        echo "$(date -u +%FT%TZ) $key (cap ${cap} s wall)" >> "$out/logs/progress.log"
        if res=$(timeout --preserve-status -s INT "$cap" "$bin" run --world continuous --map "$map" --start "$start" \
            --config "$cfg" --seed "$seed" --realtime "$realtime" --json \
            --nav2 "tcp/127.0.0.1:$(free_port)" --explore "$policy" "${alone[@]}" --params-file "$params" \
            2>"$out/logs/${key//\//_}.log"); then
          printf '{"key":"%s","size":%d,"team":%d,"seed":%d,"method":"%s","result":%s}\n' \
            "$key" "$size" "$team" "$seed" "$method" "$(tr -d '\n' <<<"$res")" >> "$out/results.jsonl"
        else
          echo "$(date -u +%FT%TZ) $key failed (see logs/${key//\//_}.log)" >> "$out/logs/progress.log"
        fi
      done
    done
  done
done
echo "$(date -u +%FT%TZ) done" >> "$out/logs/progress.log"
