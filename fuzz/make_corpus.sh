#!/usr/bin/env bash
# Seed corpora for the fuzzers (docs/testing.md, "Fuzzing") from gonio's own outputs, not from
# the shared data: the scene file of every preset, a small rendered board session (session.json,
# board.json, camera.cameramodel), the board poses located in it, the observations extracted
# from it, and a photometric.json around the response measured on a rendered exposure sweep.
# usage: bash fuzz/make_corpus.sh GONIO_BINARY OUT_DIR      (about a minute)
set -euo pipefail
gonio="$1"
out="$2"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"/{session,board,camera_model,photometric,observations,scene}

for p in default flat-field exposure-sweep sfs-sphere sfs-vase sfs-bumps; do
  "$gonio" -v 0 synth --preset "$p" --write-scene "$out/scene/$p.json" > /dev/null
done

# The default scene at 640x480 with 6 views, so it renders in seconds.
python3 - "$out/scene/default.json" "$work/small.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
c = s["camera"]
c["width"], c["height"] = 640, 480
c["intrinsics"][:4] = [550.0, 550.0, 319.5, 239.5]
s["views"]["rings_deg"] = [20.0, 45.0]
s["views"]["per_ring"] = 3
json.dump(s, open(sys.argv[2], "w"), indent=1)
PY
"$gonio" -v 0 synth --scene "$work/small.json" --out "$work/session" > /dev/null
cp "$work/session/session.json" "$out/session/"
cp "$work/session/board.json" "$out/board/"
cp "$work/session/camera.cameramodel" "$out/camera_model/"
for p in sfs-sphere; do
  "$gonio" -v 0 synth --preset "$p" --out "$work/$p" > /dev/null
  cp "$work/$p/camera.cameramodel" "$out/camera_model/$p.cameramodel"
done

"$gonio" -v 0 locate --session "$work/session" --camera "$work/session/camera.cameramodel" \
  --out "$work/poses.json" > /dev/null
"$gonio" -v 0 extract --session "$work/session" --camera "$work/session/camera.cameramodel" \
  --poses "$work/poses.json" --assume-linear --patch 8 --out "$work/observations.csv" > /dev/null
# Keep the seed small: the header and the first rows.
head -n 40 "$work/observations.csv" > "$out/observations/observations.csv"

# photometric.json around a measured response (docs/formats.md), with and without a map.
python3 - "$out/scene/exposure-sweep.json" "$work/sweep.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["camera"]["width"], s["camera"]["height"] = 160, 120
s["camera"]["intrinsics"][:4] = [140.0, 140.0, 79.5, 59.5]
s["photometric"]["bit_depth"] = 12  # 4096 entries: the smallest depth the renderer writes besides 8
s["photometric"]["black_level"] = 16.0
json.dump(s, open(sys.argv[2], "w"), indent=1)
PY
"$gonio" -v 0 synth --scene "$work/sweep.json" --out "$work/sweep" > /dev/null
python3 - "$work/sweep" <<'PY'
import json, sys
frames = json.load(open(sys.argv[1] + "/session.json"))["frames"]
with open(sys.argv[1] + "/image_list.txt", "w") as f:
    for fr in frames:
        f.write("%s %.9g\n" % (fr["file"], fr["exposure_s"]))
PY
"$gonio" -v 0 photometric response --sweep "$work/sweep" --bit-depth 12 \
  --out "$work/response.json" > /dev/null
python3 - "$work/response.json" "$out/photometric" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
r.pop("provenance", None)
# 6 significant digits: the 4096-entry table stays a seed of about 50 kB.
r["inverse_response"] = [[float("%.6g" % v) for v in c] for c in r["inverse_response"]]
for name, vignette, e in (("photometric.json", "photometric_vignette.tiff", None),
                          ("linear_no_map.json", None, 2.5)):
    j = {"response": r, "vignette": vignette, "read_noise_dn": 0.5, "electrons_per_dn": e}
    json.dump(j, open(sys.argv[2] + "/" + name, "w"))
# With V's input and a radial V's response kernel (the fuzz target writes the input's TIFF).
j = {"response": r, "vignette": "photometric_vignette.tiff", "read_noise_dn": 0.5,
     "electrons_per_dn": None,
     "vignette_input": {"raw_values": "photometric_vignette_input.tiff", "cell_px": 16,
                        "response_kernel": {"v": [-0.3, 0, 0], "truncation": [0.01, -0.02, 0],
                                            "covered_radius": 0.5, "raw": [1000, 1001.5],
                                            "weight": [[0.1, 0, 0], [-0.1, 0, 0]]}}}
json.dump(j, open(sys.argv[2] + "/radial_kernel.json", "w"))
PY
ls -l "$out"/*
