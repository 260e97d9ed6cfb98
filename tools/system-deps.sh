#!/bin/sh
# System packages for the tests that drive a real Blender binary (tests/binary):
#   blender       Debian's Blender 3.4.1 (headless bakes and the GUI under Xvfb)
#   python3-numpy numpy for that Blender's Python (the system Python 3.11)
#   xvfb          xvfb-run, a virtual X display for the GUI test
#   xdotool       sends keys (Esc) to the Blender window
#   imagemagick   `import -window root` screenshots
# Installs only what is missing, with apt-get, non-interactively; runs `apt-get update`
# once and only when something has to be installed. Quick and silent when all are present.
set -eu

# package:command-or-path that proves it is installed
WANT="blender:blender python3-numpy:/usr/lib/python3/dist-packages/numpy xvfb:xvfb-run xdotool:xdotool imagemagick:import"

missing=""
for pair in $WANT; do
    pkg=${pair%%:*}
    probe=${pair#*:}
    case $probe in
        /*) [ -e "$probe" ] && continue ;;
        *) command -v "$probe" >/dev/null 2>&1 && continue ;;
    esac
    missing="$missing $pkg"
done

[ -z "$missing" ] && exit 0

if ! command -v apt-get >/dev/null 2>&1; then
    echo "system-deps: apt-get not found; install these by hand:$missing" >&2
    exit 1
fi

SUDO=""
if [ "$(id -u)" != 0 ]; then
    if command -v sudo >/dev/null 2>&1; then
        SUDO="sudo"
    else
        echo "system-deps: not root and no sudo; as root run: apt-get install -y$missing" >&2
        exit 1
    fi
fi

echo "system-deps: installing$missing"
export DEBIAN_FRONTEND=noninteractive
$SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -q
# shellcheck disable=SC2086  # $missing is a word list on purpose
$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $missing
