#!/bin/bash
# Re-runs every ground-truth measurement of test/real_clips/*.yaml (frames go to /tmp/clips, ~2.7 GB).
# Needs OpenCV (decode only), /usr/bin/python3 with numpy, ImageMagick for the eye-check crops (eyecrop.sh).
# Usage: test/real_clips/measure/run_all.sh [/path/to/shared/data]   (default: ../shared/data from the repo root)
set -e
M=$(cd "$(dirname "$0")" && pwd)
DATA=${1:-$(cd "$M/../../.." && pwd)/../shared/data}
PY=/usr/bin/python3
g++ -O2 -std=c++17 "$M/dump_frames.cpp" -o /tmp/dump_frames $(pkg-config --cflags --libs opencv4)
for c in pendulum_bauble tennis_ball_drop hanging_ball_rope_handheld pendulum_dark_bg_metre_stick \
         pendulum_green_bg_small_bob pingpong_bounce_table spring_bead_in_oil cylinder_rolling_incline; do
  mkdir -p /tmp/clips/$c; [ -f /tmp/clips/$c/index.txt ] || nice /tmp/dump_frames "$DATA/videos/$c.mp4" /tmp/clips/$c
done
mkdir -p /tmp/clips/tendon_finger_bending
[ -f /tmp/clips/tendon_finger_bending/index.txt ] || nice /tmp/dump_frames "$DATA/videos/tendon_finger_bending.mp4" /tmp/clips/tendon_finger_bending 1 0.5
cd "$M"
echo "== pendulum_bauble"
$PY track_color.py pendulum_bauble 29.75 '[[[0,120,70],[10,255,255]],[[170,120,70],[180,255,255]]]' 522 248 80
$PY pendulum.py /tmp/clips/pendulum_bauble/track_color.txt 0 20
$PY track_bgsub.py pendulum_bauble 29.75 522 248 --thr 40 --win 70 --min 200 --predict --bgk 2
$PY pendulum.py /tmp/clips/pendulum_bauble/track_bgsub.txt 0 20
echo "== tennis_ball_drop"
$PY dupframes.py tennis_ball_drop | tail -2
$PY track_bgsub.py tennis_ball_drop 30 557 144 --thr 40 --win 110 --hsv '[[[40,40,180],[62,120,255]]]' --out track_bgcol.txt
$PY track_bgsub.py tennis_ball_drop 30 557 144 --thr 40 --win 110 --hsv '[[[25,40,120],[75,255,255]]]' --out track_bgsub.txt
for f in track_bgcol track_bgsub; do for c in 3 8; do
  $PY bounce.py /tmp/clips/tennis_ball_drop/$f.txt 30 6-34,37-86,89-109 --exclude 92 --shift 93:1 --ycol $c; done; done
echo "== pingpong_bounce_table"
$PY track_color.py pingpong_bounce_table 30 '[[[5,125,150],[25,255,255]]]' 318 117 160
for c in 3 9; do $PY bounce.py /tmp/clips/pingpong_bounce_table/track_color.txt 30 \
  7-9,11-18,20-26,28-34,36-42,44-49,51-55,57-61,63-67,69-72,74-77,79-82,84-87 --ycol $c; done
echo "== hanging_ball_rope_handheld"
$PY track_color.py hanging_ball_rope_handheld 29.921 '[[[0,90,70],[9,255,255]],[[170,90,70],[180,255,255]]]' 22 478 100
$PY track_ncc.py hanging_ball_rope_handheld 29.921 200 288,68,34,56 12 track_hook.txt
$PY hanging_rope.py
echo "== pendulum_dark_bg_metre_stick"
$PY track_blob.py pendulum_dark_bg_metre_stick 30 224 316 --f0 36 --v0=-30,-8 --thr 50 --gmin 110 --win 30 --amin 15 --amax 300
$PY pendulum.py /tmp/clips/pendulum_dark_bg_metre_stick/track_blob.txt 1.2 5.75
echo "== pendulum_green_bg_small_bob"
$PY track_bgsub.py pendulum_green_bg_small_bob 25 462 588 --thr 45 --win 55 --min 20 --predict --roi 140,70,1000,560 --bgk 2
$PY track_blob.py pendulum_green_bg_small_bob 25 462 588 --thr 35 --gmin 130 --win 45 --amin 6 --amax 400 --roi 140,70,1000,532
for f in track_bgsub track_blob; do $PY pendulum.py /tmp/clips/pendulum_green_bg_small_bob/$f.txt 0 13 569 106; done
$PY stopwatch.py 20
echo "== tendon_finger_bending"
$PY track_ncc.py tendon_finger_bending 30 0 548,282,72,50 14 track_tip.txt
$PY track_ncc.py tendon_finger_bending 30 0 330,176,64,30 10 track_bar1.txt
$PY track_ncc.py tendon_finger_bending 30 0 525,250,60,45 14 track_bar3.txt
$PY finger.py
echo "== cylinder_rolling_incline"
$PY track_bgsub.py cylinder_rolling_incline 29.97 294 117 --thr 14 --win 24 --min 30 --predict --bgk 2
$PY rolling.py
echo "== spring_bead_in_oil"
$PY track_blob.py spring_bead_in_oil 30 322 145 --f0 24 --dark --thr=-1000 --gmin 60 --win 30 --amin 4 --amax 120 --roi 295,0,55,420
$PY vertical.py /tmp/clips/spring_bead_in_oil/track_blob.txt 0.9 7.0
