#!/usr/bin/env bash
# Install the rendering peer (VTK through pyvista, headless on the CPU with Mesa's EGL /
# llvmpipe) that scripts/compare_render.py runs through ../shared/peers/render_vtk.py.
#
#   bash scripts/setup_render_peer.sh          # idempotent; prints the installed versions
#
# Environment:
#   VOXKIT_PEER_VENV  where the venv goes (default $HOME/.cache/voxkit-peers/venv, outside the
#                     repository's tracked files)
#   PYTHON            interpreter that creates the venv (default python3; needs >= 3.10)
#   SKIP_APT=1        do not touch Debian packages (e.g. not root and they are already there)
#
# What it installs:
#   * Debian: libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 (Mesa's EGL + llvmpipe, no X server).
#     VTK's 9.7 wheel links only libc/libstdc++ and dlopens the GL libraries at run time; with
#     vtkEGLRenderWindow it loads libEGL, libEGL_mesa, libgbm and swrast_dri.so (with their own
#     dependencies) and no X library (checked with LD_DEBUG=files). `apt-get update` runs once,
#     and only when one of them is missing. Also `time` (GNU /usr/bin/time): compare_render.py
#     takes each process's peak RSS from it.
#   * PyPI, pinned: vtk==9.7.2 pyvista==0.49.1, and numpy, pynrrd (render_vtk.py's .nhdr/.nrrd
#     loader), trimesh (its .binvox loader), pillow (its PNG writer), embreex (Intel Embree's
#     Python binding: scripts/embree_rays.py, compare_render.py --tools embree).
# At the end it imports everything, renders one tiny off-screen frame through EGL and prints
# the versions and the GL renderer string (expected: llvmpipe).
set -euo pipefail

VENV="${VOXKIT_PEER_VENV:-$HOME/.cache/voxkit-peers/venv}"
PYTHON="${PYTHON:-python3}"
PIP_PKGS=(vtk==9.7.2 pyvista==0.49.1 numpy pynrrd trimesh pillow embreex==4.4.0.post1)
DEB_PKGS=(libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 time)

say() { printf '[setup_render_peer] %s\n' "$*" >&2; }

# -- Debian packages ---------------------------------------------------------------------
if [[ "${SKIP_APT:-0}" != 1 ]]; then
    missing=()
    for p in "${DEB_PKGS[@]}"; do
        if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
            missing+=("$p")
        fi
    done
    if ((${#missing[@]})); then
        SUDO=""
        if [[ $(id -u) != 0 ]]; then
            command -v sudo >/dev/null || { say "need root (or sudo) to install: ${missing[*]}"; exit 1; }
            SUDO="sudo"
        fi
        say "apt-get install ${missing[*]}"
        $SUDO apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
    else
        say "Debian packages already installed"
    fi
fi

# -- venv ----------------------------------------------------------------------------------
if [[ ! -x "$VENV/bin/python" ]]; then
    say "creating venv $VENV with $($PYTHON --version 2>&1)"
    mkdir -p "$(dirname "$VENV")"
    if ! "$PYTHON" -m venv "$VENV"; then
        # Debian's own python3 needs python3-venv for ensurepip
        rm -rf "$VENV"
        if [[ "${SKIP_APT:-0}" != 1 ]] && command -v apt-get >/dev/null; then
            say "venv failed: installing python3-venv"
            SUDO=""; [[ $(id -u) != 0 ]] && SUDO="sudo"
            $SUDO apt-get update -qq
            DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq python3-venv
            "$PYTHON" -m venv "$VENV"
        else
            exit 1
        fi
    fi
fi

# pip is quick when everything is already satisfied, so this line is the idempotent part
if ! "$VENV/bin/python" - "${PIP_PKGS[@]}" <<'EOF' 2>/dev/null
import sys
from importlib.metadata import version, PackageNotFoundError
for spec in sys.argv[1:]:
    name, _, want = spec.partition("==")
    try:
        have = version(name)
    except PackageNotFoundError:
        sys.exit(1)
    if want and have != want:
        sys.exit(1)
EOF
then
    say "pip install ${PIP_PKGS[*]}"
    "$VENV/bin/python" -m pip install -q --upgrade pip
    "$VENV/bin/python" -m pip install -q "${PIP_PKGS[@]}"
else
    say "Python packages already installed"
fi

# -- check: import everything and render one small off-screen frame through EGL -----------
VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow "$VENV/bin/python" - <<'EOF'
import json, platform, sys
from importlib.metadata import version
import numpy, nrrd, trimesh, PIL, vtk, pyvista as pv

p = pv.Plotter(off_screen=True, window_size=[64, 64])
p.add_mesh(pv.Sphere())
img = p.screenshot(return_img=True)
rw = p.render_window
caps = rw.ReportCapabilities() or ""
gl = {k: l.split(":", 1)[1].strip() for l in caps.splitlines()
      for k, key in (("gl_renderer", "OpenGL renderer string"), ("gl_version", "OpenGL version string"))
      if key in l}
p.close()
if img.shape[:2] != (64, 64):
    sys.exit(f"off-screen frame has shape {img.shape}")
print(json.dumps({
    "venv_python": sys.executable, "python": platform.python_version(),
    "vtk": vtk.vtkVersion.GetVTKVersion(), "pyvista": pv.__version__, "numpy": numpy.__version__,
    "pynrrd": version("pynrrd"), "trimesh": trimesh.__version__, "pillow": PIL.__version__,
    "render_window": rw.GetClassName(), **gl,
}))
EOF
