#!/usr/bin/env bash
# The Debian package of a build (`cpack -G DEB`), unpacked with dpkg -x into a temporary root (not
# installed): its Depends line must name the package of every shared library that its programs and the
# Python module load directly; a tool runs from it, the Python module imports from it (Debian's
# /usr/bin/python3, from another folder), and a downstream project builds against its CMake package.
# Usage: check_deb.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src="$1" build="$2"
for tool in cpack dpkg-deb dpkg-shlibdeps readelf; do
  command -v "$tool" > /dev/null || { echo "check_deb: $tool is missing (apt-get install dpkg-dev binutils cmake)"; exit 1; }
done
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# -B: the package and CPack's staging folder go to the temporary folder, not into the build.
cpack --config "$build/CPackConfig.cmake" -G DEB -B "$tmp/cpack" > "$tmp/cpack.log" 2>&1 \
  || { cat "$tmp/cpack.log"; exit 1; }
debs=("$tmp"/cpack/*.deb)
[[ ${#debs[@]} -eq 1 && -f "${debs[0]}" ]] || { echo "cpack made ${#debs[@]} packages"; cat "$tmp/cpack.log"; exit 1; }
deb="${debs[0]}"
echo "$(basename "$deb"): $(du -h "$deb" | cut -f1)"
depends="$(dpkg-deb -f "$deb" Depends)"
echo "Depends: $depends"
# The package names of Depends (alternatives included, versions dropped).
declared="$(tr ',|' '\n\n' <<< "$depends" | sed -E 's/\(.*\)//; s/:[a-z0-9]+$//; s/^ +//; s/ +$//' | sort -u)"

dpkg -x "$deb" "$tmp/root"
for f in usr/bin/train-forest usr/lib/cmake/smseg/smsegConfig.cmake usr/lib/python3/dist-packages/smseg/__init__.py; do
  [[ -e "$tmp/root/$f" ]] || { echo "not in the package: /$f"; exit 1; }
done

# Each ELF file (the tools, the Python module): its own NEEDED libraries (dpkg-shlibdeps reads these,
# not the libraries they load in turn, whose packages depend on theirs), resolved by ldd.
elves=0
: > "$tmp/libs.txt"
while IFS= read -r -d '' f; do
  [[ "$(head -c 4 "$f" | od -An -c | tr -d ' ')" == "177ELF" ]] || continue
  elves=$((elves + 1))
  resolved="$(ldd "$f")"
  for lib in $(readelf -d "$f" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
    # "libfoo.so.1 => /path (addr)", or "/lib64/ld-linux-x86-64.so.2 (addr)" for the loader.
    path="$(awk -v l="$lib" '$1 == l && $2 == "=>" {print $3; exit} $1 ~ "/" l "$" {print $1; exit}' <<< "$resolved")"
    [[ -n "$path" && "$path" != "not" ]] || { echo "${f#"$tmp/root"}: $lib is not found"; exit 1; }
    echo "$path" >> "$tmp/libs.txt"
  done
done < <(find "$tmp/root" -type f -print0)
((elves > 1)) || { echo "no programs in the package"; exit 1; }
# Their owner packages, with one dpkg -S for all (it reads its whole database each time). ldd may print
# /lib/... for a file dpkg knows as /usr/lib/... or the other way round (merged /usr), or a symlink that
# dpkg knows by its target: every spelling is asked, and each library must be owned under one of them.
sort -u -o "$tmp/libs.txt" "$tmp/libs.txt"
spellings() { local real; real="$(readlink -f "$1")"; printf '%s\n' "$1" "${1#/usr}" "/usr$1" "$real" "${real#/usr}"; }
while read -r path; do spellings "$path"; done < "$tmp/libs.txt" | sort -u > "$tmp/spellings.txt"
xargs dpkg -S < "$tmp/spellings.txt" 2> /dev/null | grep -v '^diversion' | sed -E 's/^([^:,]+)(:[a-z0-9]+)?: (.*)$/\3 \1/' > "$tmp/owners.txt" || true
needed_packages=""
while read -r path; do
  package="$(spellings "$path" | awk 'NR == FNR {want[$1]; next} $1 in want {print $2; exit}' - "$tmp/owners.txt")"
  [[ -n "$package" ]] || { echo "no Debian package owns $path"; exit 1; }
  needed_packages+="$package"$'\n'
done < "$tmp/libs.txt"
missing="$(comm -23 <(sort -u <<< "$needed_packages" | sed '/^$/d') <(echo "$declared"))"
[[ -z "$missing" ]] || { echo "linked but not in Depends:" $missing; exit 1; }
echo "$elves ELF files; the $(sort -u <<< "$needed_packages" | sed '/^$/d' | wc -l) packages of their libraries are all in Depends"

# A tool from the unpacked root.
"$tmp/root/usr/bin/train-forest" --help > "$tmp/help.txt" || { echo "train-forest --help failed"; exit 1; }
grep -qi "usage" "$tmp/help.txt" || { echo "train-forest --help printed no usage"; exit 1; }

# The Python module, from another folder with Debian's interpreter.
mkdir -p "$tmp/elsewhere"
file="$(cd "$tmp/elsewhere" && env -u PYTHONHOME PYTHONPATH="$tmp/root/usr/lib/python3/dist-packages" \
        /usr/bin/python3 -c "import smseg; print(smseg.__file__)")" || { echo "import smseg failed"; exit 1; }
[[ "$file" == "$tmp/root/"* ]] || { echo "smseg was imported from $file, not from the package"; exit 1; }

# A downstream project against the unpacked /usr: every library, C++ only.
cp -r "$src/tests/package/consumers/all" "$tmp/all"
cmake -S "$tmp/all" -B "$tmp/all/build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$tmp/root/usr" \
  > "$tmp/all/configure.log" 2>&1 || { cat "$tmp/all/configure.log"; exit 1; }
grep -q "$tmp/root/usr/lib/cmake/smseg" "$tmp/all/build/CMakeCache.txt" || { echo "smseg was not found in the package"; exit 1; }
cmake --build "$tmp/all/build" -j2 > "$tmp/all/build.log" 2>&1 || { cat "$tmp/all/build.log"; exit 1; }
mkdir -p "$tmp/scratch"
"$tmp/all/build/all-consumer" "$tmp/scratch" > "$tmp/all/run.log" || { cat "$tmp/all/run.log"; exit 1; }
echo "Debian package: Depends, tool, Python module and CMake package: ok"
