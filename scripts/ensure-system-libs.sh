#!/usr/bin/env bash
# bpy needs a few X11/GL client libraries from the system (toolchain notes 1.5). Install them when missing
# and we may (root with apt-get); otherwise say what is missing and go on: the Blender tests will then fail
# with the loader's own message.
set -u
need=()
for lib in libX11.so.6 libXrender.so.1 libXfixes.so.3 libXi.so.6 libxkbcommon.so.0 libSM.so.6 libICE.so.6 libGL.so.1; do
  ldconfig -p | grep -q "$lib" || need+=("$lib")
done
[ ${#need[@]} -eq 0 ] && exit 0
echo "system libraries missing for bpy: ${need[*]}" >&2
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
    libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libsm6 libice6 libgl1 >/dev/null
fi
exit 0
