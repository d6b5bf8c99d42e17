#!/usr/bin/env bash
# Regenerates docs/images/architecture.svg, the module map of docs/architecture.md, from the build itself:
# CMake's --graphviz over a fresh configure, our libraries and tools only (outside libraries, tests,
# benchmarks and the warnings target left out). Needs Graphviz (apt-get install graphviz).
# Usage: bash docs/architecture-graph.sh
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
cat > "$tmp/CMakeGraphVizOptions.cmake" <<'OPTIONS'
set(GRAPHVIZ_GRAPH_NAME "smseg")
set(GRAPHVIZ_EXTERNAL_LIBS FALSE)
set(GRAPHVIZ_GENERATE_PER_TARGET FALSE)
set(GRAPHVIZ_GENERATE_DEPENDERS FALSE)
set(GRAPHVIZ_IGNORE_TARGETS "^test_" "^bench_" "^smseg_warnings$")
OPTIONS
cmake -S "$here" -B "$tmp" -DSMSEG_BUILD_TESTS=OFF -DSMSEG_BUILD_BENCHMARKS=OFF --graphviz="$tmp/smseg.dot" >/dev/null
# Without CMake's legend; libraries as boxes (solid arrows: public links, dotted: private).
python3 - "$tmp/smseg.dot" "$tmp/smseg2.dot" <<'PY'
import re, sys
dot = open(sys.argv[1]).read()
dot = re.sub(r"subgraph clusterLegend \{.*?\n\}\n", "", dot, flags=re.S)
dot = dot.replace("shape = octagon", "shape = box, style = filled, fillcolor = lightblue")
open(sys.argv[2], "w").write(dot.replace('digraph "smseg" {', 'digraph "smseg" {\n  ranksep = 0.8;', 1))
PY
dot -Tsvg "$tmp/smseg2.dot" -o "$here/docs/images/architecture.svg.tmp"
mv "$here/docs/images/architecture.svg.tmp" "$here/docs/images/architecture.svg"
echo "wrote docs/images/architecture.svg"
