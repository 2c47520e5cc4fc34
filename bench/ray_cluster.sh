#!/usr/bin/env bash
# A two-node Ray cluster on this machine, as a real cluster is set up, then one short RLlib PPO run
# on it whose env runners sample on both nodes. By hand, not in CI:
#
#     PYTHON=.venv/bin/python bash bench/ray_cluster.sh
#
# * Loopback only: the script re-runs itself in a private network namespace (`unshare --net`, as
#   root) whose only interface is lo, so every Ray process binds, advertises and connects on
#   127.0.0.1 (Ray 2.60 on Linux replaces a loopback address by the machine's routable one when
#   it has one: ray._private.services.resolve_ip_for_localhost; here there is none). The nodes are
#   started with --node-ip-address=127.0.0.1 and the driver gets RAY_ADDRESS=127.0.0.1:PORT.
#   NO_NETNS=1 skips the namespace (then Ray advertises the machine's address).
# * Token authentication (Ray 2.60's `ray start --head` turns it on): RAY_AUTH_MODE=token and one
#   cluster token in RAY_AUTH_TOKEN, exported to the head, the second node and the driver. On real
#   machines: `ray get-auth-token --generate` on the head, then copy ~/.ray/auth_token to every node
#   (or set RAY_AUTH_TOKEN there) before `ray start --address=HEAD_IP:PORT`.
# * Each node has num_cpus=1 and the run asks for 2 env runners of 1 CPU each, so Ray must place one
#   runner on each node; the driver prints the cluster's nodes and, per iteration, the env steps
#   sampled on each node (ppo_config's per-node counter).
# * Its own --temp-dir, so a plain `ray.init()` elsewhere on this machine does not join this
#   cluster; on every exit (trap) it stops exactly the processes it started (by pid: the two
#   blocking `ray start`s, then any process still running from its temp dir). Not `ray stop`, which
#   would stop every Ray instance on the machine.
# * Bounded: the training run is killed after TIMEOUT_S (default 600) seconds.
set -euo pipefail

if [ -z "${TIN_SWARM_NETNS:-}" ] && [ "${NO_NETNS:-0}" != 1 ]; then
    exec unshare --net -- env TIN_SWARM_NETNS=1 bash -c 'ip link set lo up && exec bash "$0" "$@"' \
        "${BASH_SOURCE[0]}" "$@"
fi

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PYTHON="${PYTHON:-python3}"
RAY="${RAY:-$(dirname "$(command -v "$PYTHON")")/ray}"
[ -x "$RAY" ] || RAY=ray
PORT="${PORT:-6391}"
TIMEOUT_S="${TIMEOUT_S:-600}"
ITERATIONS="${ITERATIONS:-2}"
TMPD="$(mktemp -d /tmp/tin_swarm_ray.XXXXXX)"
PIDS=()

cleanup() {
    local rc=$?
    trap - EXIT INT TERM
    echo "== stopping both nodes"
    for pid in "${PIDS[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done
    sleep 3
    # whatever is left of this cluster: processes whose command line names this run's temp dir
    for pid in $(pgrep -f -- "$TMPD" || true); do kill -TERM "$pid" 2>/dev/null || true; done
    sleep 2
    for pid in $(pgrep -f -- "$TMPD" || true); do kill -KILL "$pid" 2>/dev/null || true; done
    left=$(pgrep -f -- "$TMPD" | wc -l || true)
    echo "== processes of this cluster still running: ${left}"
    rm -rf "$TMPD"
    exit "$rc"
}
trap cleanup EXIT INT TERM

# -- the cluster's token: every node and the driver get the same one ------------------------
export RAY_AUTH_MODE=token
RAY_AUTH_TOKEN="$("$PYTHON" -c 'import secrets; print(secrets.token_hex(32))')"
export RAY_AUTH_TOKEN
export PYTHONPATH="$REPO${PYTHONPATH:+:$PYTHONPATH}"  # workers import this checkout
export RAY_USAGE_STATS_ENABLED=0

echo "== head node: 127.0.0.1:$PORT"
"$RAY" start --head --block --node-ip-address=127.0.0.1 --port="$PORT" --num-cpus=1 \
    --include-dashboard=false --temp-dir="$TMPD" --disable-usage-stats > "$TMPD/head.log" 2>&1 &
PIDS+=($!)
for _ in $(seq 60); do
    grep -q "Ray runtime started" "$TMPD/head.log" && break
    kill -0 "${PIDS[0]}" 2>/dev/null || { cat "$TMPD/head.log"; exit 1; }
    sleep 1
done
grep -q "Ray runtime started" "$TMPD/head.log" || { cat "$TMPD/head.log"; exit 1; }

echo "== second node joins 127.0.0.1:$PORT"
"$RAY" start --block --address="127.0.0.1:$PORT" --node-ip-address=127.0.0.1 --num-cpus=1 \
    --temp-dir="$TMPD" --disable-usage-stats > "$TMPD/node2.log" 2>&1 &
PIDS+=($!)
for _ in $(seq 60); do
    grep -q "Ray runtime started" "$TMPD/node2.log" && break
    kill -0 "${PIDS[1]}" 2>/dev/null || { cat "$TMPD/node2.log"; exit 1; }
    sleep 1
done
grep -q "Ray runtime started" "$TMPD/node2.log" || { cat "$TMPD/node2.log"; exit 1; }

echo "== driver: RAY_ADDRESS=127.0.0.1:$PORT agents/train_rllib.py --env-runners 2"
RAY_ADDRESS="127.0.0.1:$PORT" timeout "$TIMEOUT_S" "$PYTHON" "$REPO/agents/train_rllib.py" \
    --scenario flat --n-robots 4 --max-cycles 50 --iterations "$ITERATIONS" --env-runners 2 \
    --train-batch-size 400 --minibatch-size 100 --num-epochs 1 --out-dir "$TMPD/rllib"
