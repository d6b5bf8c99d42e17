# Sourced by the CamVid script tests: a small CamVid folder cut from ../shared/data/camvid.
#   mini_camvid SHARED_DIR   sets camvid (the real folder) and tmp (removed at exit), exits 77 (skipped)
#                            without CamVid, and makes $tmp/camvid ($mini): the image and label folders
#                            linked, classes.csv copied; the caller writes $mini/frames.csv (its cut).
mini_camvid() {
  camvid="$1/data/camvid"
  [[ -f "$camvid/frames.csv" ]] || { echo "no CamVid under $1/data: skipped"; exit 77; }
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  mini="$tmp/camvid"
  mkdir -p "$mini"
  local d
  for d in train trainannot val valannot; do ln -s "$camvid/$d" "$mini/$d"; done
  cp "$camvid/classes.csv" "$mini/"
}
# frames.csv's header line and its shortest train run (0016E5_08190-08640, 16 frames at 1 Hz), the
# start of each test's cut.
header_and_short_run() {
  head -1 "$camvid/frames.csv"
  awk -F, '$1 == "0016E5" && $3 == "train" && $2 >= 8190 && $2 <= 8640' "$camvid/frames.csv"
}
