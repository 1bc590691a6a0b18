#!/usr/bin/env bash
# Installs the benchmark mesh (the Stanford bunny in Debian's libcgal-demo) and runs the BVH tracing
# benchmarks. Without the package the benchmark falls back to a procedural mesh and says so.
# Set OBSCURA_BENCH_MESH=/path/to/mesh.off to benchmark another mesh.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! dpkg -s libcgal-demo >/dev/null 2>&1; then
    echo "== installing libcgal-demo (bunny00.off lives in /usr/share/doc/libcgal-dev/data.tar.gz)"
    apt-get update
    apt-get install -y libcgal-demo
fi

echo "== cargo bench -p obscura-render --bench trace"
cargo bench -p obscura-render --bench trace "$@"
