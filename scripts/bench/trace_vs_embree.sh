#!/usr/bin/env bash
# Obscura's BVH (binary and four-wide layouts) side by side with Embree 3 on the same mesh and rays,
# one pinned core, one run. Installs Debian's libembree-dev (the harness's only use of Embree: it is
# never a dependency of the product) and libcgal-demo (the Stanford bunny), builds
# bench/embree/trace_embree.cpp with the system C++ compiler, dumps the mesh and the rays from the
# Rust benchmark, runs both and prints Mrays/s, the ratios and where Embree's hits differ from ours.
# Usage: scripts/bench/trace_vs_embree.sh [core]   (default core 1; OBSCURA_BENCH_MESH as for bench-trace.sh)
set -euo pipefail
cd "$(dirname "$0")/../.."
core="${1:-1}"

need=()
dpkg -s libembree-dev >/dev/null 2>&1 || need+=(libembree-dev)
dpkg -s libcgal-demo >/dev/null 2>&1 || need+=(libcgal-demo)
command -v g++ >/dev/null 2>&1 || need+=(g++)
if ((${#need[@]})); then
    echo "== installing ${need[*]}"
    apt-get update
    apt-get install -y "${need[@]}"
fi

out="$PWD/target/trace-vs-embree"
mkdir -p "$out"
echo "== building bench/embree/trace_embree.cpp"
g++ -O2 -std=c++17 -o "$out/trace_embree" bench/embree/trace_embree.cpp -lembree3
echo "== building the trace benchmark (release)"
cargo bench -p obscura-render --bench trace --no-run

# The machine may be shared: alternate the two sides for a few rounds and keep each one's best, so
# a burst of load elsewhere does not land on one side only.
rounds="${OBSCURA_TRACE_ROUNDS:-3}"
: >"$out/obscura.txt"
: >"$out/embree.txt"
for round in $(seq "$rounds"); do
    echo "== round $round of $rounds, core $core: Obscura (both layouts), then Embree on the same mesh and rays"
    OBSCURA_TRACE_VS_EMBREE="$out/rays.bin" taskset -c "$core" \
        cargo bench -q -p obscura-render --bench trace | tee -a "$out/obscura.txt"
    taskset -c "$core" "$out/trace_embree" "$out/rays.bin" | tee -a "$out/embree.txt"
done

echo "== Mrays/s (best round; each round the fastest of 5 passes, one thread) and ratios to Embree"
awk '
    $4 == "Mrays/s" && $3 + 0 > rate[$1 " " $2] + 0 { rate[$1 " " $2] = $3 }
    END {
        printf "%-11s %10s %10s %10s %12s %12s\n", "rays", "binary", "wide", "embree", "binary/emb", "wide/emb"
        n = split("primary incoherent shadow", sets, " ")
        for (i = 1; i <= n; i++) {
            s = sets[i]; b = rate["obscura-binary " s]; w = rate["obscura-wide " s]; e = rate["embree " s]
            printf "%-11s %10.2f %10.2f %10.2f %12.2f %12.2f\n", s, b, w, e, b / e, w / e
        }
    }' "$out/obscura.txt" "$out/embree.txt"
