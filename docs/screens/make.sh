#!/usr/bin/env bash
# Screenshots of the participant's window, as a participant sees it: every screen of a mono
# 2AFC session, a matching trial, and the start and trial screens of every stereo display
# mode, each at 1920x1080 on a virtual X server (Xvfb), driven by keystrokes (xdotool) and
# captured with ImageMagick's `import`. Writes docs/screens/*.png.
#
#   apt-get install -y --no-install-recommends xvfb xauth xdotool imagemagick
#   cargo build --release && cargo run --release -- demo     # the quick set in stimuli/out/quick
#   docs/screens/make.sh
#
# BLURLAB (default target/release/blurlab) and SET (default stimuli/out/quick) override the
# binary and the stimulus set. The experiments are small copies of the shipped ones (four
# stimuli, a break after every three trials, ready screens that wait for Space) so that every
# screen comes up within a minute; the screens are the shipped runner's.
set -euo pipefail
cd "$(dirname "$0")/../.."
BLURLAB=${BLURLAB:-target/release/blurlab}
SET=${SET:-stimuli/out/quick}
OUT=docs/screens
work=$(mktemp -d)
# A free display number (a server killed without cleaning up leaves its lock behind).
n=97
while [ -e "/tmp/.X$n-lock" ]; do n=$((n + 1)); done
display=:$n
# -noreset: the server would otherwise reset whenever the last window closes, and a window
# opening during the reset fails to connect.
Xvfb "$display" -screen 0 1920x1080x24 -nolisten tcp -noreset >/dev/null 2>&1 &
xvfb=$!
app=
cleanup() {
  [ -n "$app" ] && kill "$app" 2>/dev/null || true
  kill "$xvfb" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
export DISPLAY=$display
export XDG_RUNTIME_DIR=$work
sleep 1

# experiment VIEW TASK MODE: a small definition in $work/NAME.toml.
experiment() {
  local view=$1 task=$2 mode=$3 suffix=""
  [ "$view" = stereo ] && suffix="-stereo"
  cat >"$work/shots-$view-$task.toml" <<EOF
format = "blurlab-experiment/1"
name = "shots-$view-$task"
title = "Screenshots: T3,T5 x A3,A5 ($view, $task)"
participant_title = "Rolling ball: a video quality study"
task = "$task"
question = "$([ "$task" = match ] && echo "Which candidate is the same as the reference?" || echo "Which sequence has higher quality?")"
view = "$view"

[stimuli]
material = [2]
speed = [2]
shutter = [3, 5]
samples = [3, 5]

[briefing]
text = """
You will watch short animations of a ball rolling over a floor. They differ in how they
were rendered. High-quality renders look smooth and natural.

Watch for noise (grainy, sparkling pixels), flicker or strobing (the motion looks jerky)
and excessive blur (the ball looks smeared). There are no right or wrong answers.
"""

[[briefing.examples]]
label = "Noise"
description = "Grainy, sparkling pixels from too few samples per pixel."
stimulus = "M3-S2-T3-A1$suffix"

[[briefing.examples]]
label = "Excessive blur"
description = "The shutter is open the whole frame: the ball is smeared."
stimulus = "M2-S3-T5-A5$suffix"

[[practice]]
pair = ["M2-S2-T1-A1$suffix", "M2-S2-T4-A5$suffix"]

[presentation]
loops = 8
break_every = 3
ready_press = true

[display]
mode = "$mode"

[[attributes]]
key = "cg_experience"
question = "Do you have working experience in computer graphics?"
options = ["yes", "no"]
EOF
  echo "$work/shots-$view-$task.toml"
}

shot() { import -window root "$OUT/$1.png"; echo "$OUT/$1.png"; }
key() { xdotool key "$@"; sleep "${PAUSE:-0.8}"; }

# open VIEW TASK MODE [ARGS...]: starts the window on a new results folder, calibrated for
# this screen (a 1920-pixel, 53.1 cm wide monitor at 60 cm, 60 Hz), or with ARGS instead.
open() {
  local def
  def=$(experiment "$1" "$2" "$3")
  shift 3
  local args=(--screen-width-px 1920 --screen-width-cm 53.1 --distance-cm 60 --refresh-hz 60)
  [ $# -gt 0 ] && args=("$@")
  rm -rf "$work/results"
  "$BLURLAB" run "$def" --stimuli "$SET" --participant P01 --results "$work/results" "${args[@]}" \
    >"$work/app.log" 2>&1 &
  app=$!
  for _ in $(seq 150); do
    xdotool search --name "Rolling ball" >/dev/null 2>&1 && break
    sleep 0.2
  done
  if ! xdotool search --name "Rolling ball" >/dev/null 2>&1; then
    echo "the window did not open:" >&2
    cat "$work/app.log" >&2
    exit 1
  fi
  # Without a window manager `--fullscreen` neither fills the screen nor takes the keyboard:
  # the window is made the size of the screen instead.
  local w
  w=$(xdotool search --name "Rolling ball" | head -n 1)
  xdotool windowmove "$w" 0 0 windowsize "$w" 1920 1080
  sleep 2
  # No window manager gives it the keyboard: Tab moves between widgets only with the focus.
  xdotool windowfocus "$w"
  sleep 0.3
}

# The participant answers the attribute (Tab to "no", Space), the experimenter ticks the ruler
# check (Tab, Space) and presses Start (Tab, Enter).
fill_start() {
  key Tab
  key Tab
  key space
  key Tab
  key space
  key Tab
  key Return
  sleep 1
}

close() { kill "$app" 2>/dev/null || true; wait "$app" 2>/dev/null || true; app=; }

# ready: waits for the ready screen to have loaded the trial, then Space starts it.
ready() { sleep 1.5; key space; }
# trial KEY: a whole trial answered with KEY (8 loops of two 8-frame sequences and a gap: 5 s).
trial() { ready; sleep 6.5; key "$1"; }

# The start screen's checks: the default calibration (a 1600-pixel screen) on this 1920-pixel
# one, and no --refresh-hz on a window without a display refresh (Xvfb): Start stays disabled.
open mono 2afc mono --distance-cm 60
sleep 3
shot 00-start-checks
close

# A mono 2AFC session, screen by screen.
open mono 2afc mono
shot 01-start
fill_start
shot 02-briefing
PAUSE=0.3 key Tab
key space
sleep 1
shot 03-example
key BackSpace
key space
sleep 1
shot 04-ready
key space
sleep 0.4
shot 05-presenting
sleep 6
shot 06-answer
key 1
sleep 1
shot 07-practice-over
key space
ready
sleep 0.4
shot 08-trial
sleep 6
key 1
trial 2
trial 1
shot 09-break
key space
ready
sleep 0.4
key Escape
shot 10-quit
key Escape
sleep 6.5
key 2
trial 1
trial 2
shot 11-done
close

# A matching trial.
open mono match mono
fill_start
key space
ready
sleep 3.2
shot 12-matching
close

# Every stereo mode: the start screen and a trial.
n=13
for mode in sbs-full sbs-half top-bottom anaglyph row-interleaved; do
  open stereo 2afc "$mode"
  shot "$n-$mode-start"
  fill_start
  key space
  ready
  sleep 0.4
  shot "$((n + 1))-$mode-trial"
  close
  n=$((n + 2))
done
