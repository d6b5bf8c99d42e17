#!/usr/bin/env bash
# `pip install .` of a clone, as the README says: the source's files (git's tracked and untracked but not
# ignored ones, so uncommitted work is tested too) are copied to a temporary folder, a virtual environment
# over Debian's python3 (its numpy, setuptools, wheel, matplotlib) installs the package without build
# isolation and without any index, and from another folder the README's Python example runs on the small
# corridor with that environment's python. The module must come from the environment, and the build must
# leave nothing in the source beside build-pip/ (ignored by git).
# Usage: check_pip.sh SOURCE_DIR WORK_FOLDER
set -euo pipefail
src="$1" work="$2"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

mkdir -p "$tmp/src"
if git -C "$src" rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  # A tracked file deleted in the work tree is listed but absent: tar skips it.
  (cd "$src" && git ls-files -z --cached --others --exclude-standard \
     | tar --null --files-from=- --ignore-failed-read -cf - 2> /dev/null) | tar -xf - -C "$tmp/src"
else
  tar -C "$src" --exclude=./.git --exclude=./build --exclude='./build-*' -cf - . | tar -xf - -C "$tmp/src"
fi
[[ -f "$tmp/src/pyproject.toml" && -f "$tmp/src/setup.py" ]] || { echo "no pyproject.toml / setup.py in $src"; exit 1; }
(cd "$tmp/src" && find . -path ./build-pip -prune -o -print | sort) > "$tmp/before.txt"

/usr/bin/python3 -m venv --system-site-packages "$tmp/venv" \
  || { echo "/usr/bin/python3 -m venv failed (Debian: apt-get install python3-venv)"; exit 1; }
start=$SECONDS
(cd "$tmp/src" && "$tmp/venv/bin/pip" install -v --no-build-isolation --no-index . > "$tmp/pip.log" 2>&1) \
  || { tail -40 "$tmp/pip.log"; echo "pip install failed"; exit 1; }
echo "pip install: $((SECONDS - start)) s"
(cd "$tmp/src" && find . -path ./build-pip -prune -o -print | sort) > "$tmp/after.txt"
new="$(comm -13 "$tmp/before.txt" "$tmp/after.txt")"
[[ -z "$new" ]] || { echo "pip install left in the source:" $new; exit 1; }

# The README's example, its work folder replaced by the small corridor's; runpy returns its globals,
# from which the share of right pixels is read.
awk '/^## Use it as a library/ {on = 1} on && $0 == "```python" {inside = 1; next}
     inside && /^```/ {exit} inside {print}' "$src/README.md" > "$tmp/example.py"
grep -q '^work = "out/main/work"' "$tmp/example.py" || { echo "README: no Python example with work = \"out/main/work\""; exit 1; }
sed -i "s|^work = \"out/main/work\"|work = \"$work\"|" "$tmp/example.py"
mkdir -p "$tmp/run"
out="$(cd "$tmp/run" && env -u PYTHONPATH -u PYTHONHOME MPLBACKEND=Agg "$tmp/venv/bin/python" -c '
import importlib.metadata, runpy, smseg
g = runpy.run_path("../example.py")
print(smseg.__file__)
print(importlib.metadata.version("smseg"))
print("%.3f" % g["right"])
')" || { echo "the README example failed"; exit 1; }
echo "$out"
mapfile -t lines <<< "$out"
[[ "$(realpath "${lines[0]}")" == "$(realpath "$tmp/venv")"/* ]] || { echo "smseg was imported from ${lines[0]}, not the venv"; exit 1; }
version="$(sed -n 's/^project(smseg VERSION \([0-9.]*\).*/\1/p' "$src/CMakeLists.txt")"
[[ "${lines[1]}" == "$version" ]] || { echo "installed version ${lines[1]}, CMake's $version"; exit 1; }
awk -v a="${lines[2]}" 'BEGIN {exit !(a > 0.3)}' || { echo "${lines[2]} of the pixels right is not above chance"; exit 1; }
[[ "$(head -c 4 "$tmp/run/frame.png" | od -An -c | tr -d ' ')" == "211PNG" && $(stat -c %s "$tmp/run/frame.png") -gt 1000 ]] \
  || { echo "the example wrote no PNG"; exit 1; }
echo "pip install, import from the venv, README example: ok"
