#!/usr/bin/env bash
# Off-screen rendering for pyvista needs EGL/Mesa. Install it when we are root on
# Debian; otherwise say what is missing. femref degrades with a clear message
# (femref.render.offscreen_available) when it is absent.
set -u
if ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1' && ldconfig -p 2>/dev/null | grep -q 'libGL.so.1'; then
    exit 0
fi
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing EGL/Mesa for off-screen rendering (libegl1 libegl-mesa0 libgl1-mesa-dri libgl1)"
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 >/dev/null) \
        || echo "warning: could not install EGL/Mesa; pyvista rendering will be unavailable"
else
    echo "note: EGL/Mesa not found and not root; pyvista rendering will be unavailable (install libegl1 libegl-mesa0 libgl1-mesa-dri)"
fi
