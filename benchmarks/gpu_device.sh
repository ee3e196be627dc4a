#!/usr/bin/env bash
# GPU frame times on a lent machine that has the NVIDIA driver (its EGL vendor library) and a
# Python with numpy, numba and scipy, but no GL loader and no network (the device tool's
# machines): `prepare` here, then `run` there with `.gl` carried.
#   bash benchmarks/gpu_device.sh prepare        # .gl/lib: libglvnd's loaders from this
#                                                # machine; .gl/py: the pure-Python and
#                                                # wheel dependencies numba's stack lacks
#   bash benchmarks/gpu_device.sh run [bench_gpu.py arguments]   # on the GPU machine
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
case "${1:-}" in
prepare)
    PY_VERSION="${PY_VERSION:-3.12}"
    rm -rf .gl && mkdir -p .gl/lib .gl/py
    for lib in libEGL.so.1 libGLdispatch.so.0 libOpenGL.so.0 libGL.so.1 libGLX.so.0; do
        cp -L "/usr/lib/x86_64-linux-gnu/$lib" .gl/lib/
    done
    "${PREP_PYTHON:-.venv/bin/python}" -m pip install -q --target .gl/py --no-deps --only-binary=:all: \
        --python-version "$PY_VERSION" --platform manylinux_2_28_x86_64 \
        --platform manylinux2014_x86_64 --platform manylinux_2_17_x86_64 \
        'esper>=3.5,<4' 'pyglet>=2.1.19,<3' 'pyrr>=0.10.3,<0.11' multipledispatch \
        'shapely>=2.0' 'pillow>=10'
    du -sh .gl
    ;;
run)
    shift
    PY="${GPU_PYTHON:-/opt/torch/.venv/bin/python3}"
    NV="${NVIDIA_LIBS:-/usr/local/nvidia/lib64}"
    export LD_LIBRARY_PATH="$PWD/.gl/lib:$NV:${LD_LIBRARY_PATH:-}"
    export __EGL_VENDOR_LIBRARY_DIRS="${__EGL_VENDOR_LIBRARY_DIRS:-/usr/share/glvnd/egl_vendor.d}"
    export PYTHONPATH="$PWD:$PWD/.gl/py" PYGLET_HEADLESS=1
    export NUMBA_CACHE_DIR="${NUMBA_CACHE_DIR:-/tmp/riverflow-numba}"
    "$PY" -c "from riverflow.engine import gl; gl.acquire_context(); print(gl.renderer_name())"
    "$PY" benchmarks/bench_gpu.py "$@"
    ;;
*)
    echo "usage: $0 prepare | run [bench_gpu.py arguments]" >&2
    exit 2
    ;;
esac
