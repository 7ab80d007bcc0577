#!/usr/bin/env python3
"""Render one view with VTK's CPU ray caster, in ercube's conventions.

The peer of `ercube peer vtk` (docs/peers.md). It takes ercube's own view
options (volume, camera, transfer function), renders offscreen with
``vtkFixedPointVolumeRayCastMapper``, times ``--frames`` frames after one
warm-up frame, writes the image as float32 ``H x W x 4`` (``--npy``, RGB
premultiplied over black, row 0 at the top, like ``ercube render --npy``)
and/or PNG, and prints one JSON object on stdout: ``time_s`` is the median
of the mapper's own ``GetTimeToDraw`` (ray casting without the window's
blit), ``wall_time_s`` the median wall clock around ``Render()``. With ``--ref ref.npy``
(``ercube render --method reference --npy ref.npy``) it also reports the
RMSE (RGB in [0, 1]) and largest 8-bit difference against it.

Conventions matched to ercube (README, "Conventions"):
- voxel (x, y, z) has its centre at (x, y, z) * spacing; x fastest in files;
- outside the voxel centres each voxel's value holds over its cell up to the
  faces at -1/2 and N - 1/2 (replicate padding): the volume is padded by one
  replicated voxel per side and cropped to those faces (``--no-pad``: VTK's
  own bounds, the voxel centres);
- camera eye / look-at / up / vertical fov; ercube is right-handed like VTK
  (looking along +z with up +y, +x is on the image's left);
- opacity per unit world length: ``ScalarOpacityUnitDistance = 1`` (VTK
  corrects per step as 1 - (1 - a)^(ds / unit));
- transfer function: the same control points (TOML ``[[point]]`` value,
  rgba), piecewise linear, constant beyond its ends.

If the running interpreter has no ``vtk``, the script makes (once) a venv
beside itself, ``.venv`` (or ``$ERCUBE_PEER_VENV``), installs ``vtk`` and
``numpy`` from PyPI into it and re-runs itself there; if that fails it exits
with status 2 and one line on stderr naming the problem.

``--self-test`` renders a volume holding one bright voxel off centre and
checks that VTK puts it on the pixel ercube's camera model predicts.
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEN_HEADER = 62


def fail(msg):
    print(f"vtk.py: error: {msg}", file=sys.stderr)
    sys.exit(2)


def ensure_vtk(argv):
    """Re-runs this script in a venv with vtk and numpy unless they import."""
    if not os.environ.get("DISPLAY"):
        # Offscreen without an X server: VTK's wheels pick EGL, else OSMesa.
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    try:
        import numpy  # noqa: F401
        import vtkmodules  # noqa: F401
        return
    except ImportError:
        pass
    if os.environ.get("ERCUBE_PEER_IN_VENV") == "1":
        fail(f"the venv at {sys.prefix} has no working vtk/numpy: remove it and rerun")
    venv = Path(os.environ.get("ERCUBE_PEER_VENV", HERE / ".venv"))
    py = venv / "bin" / "python"
    if not py.exists():
        print(f"vtk.py: making {venv} with vtk and numpy (once)", file=sys.stderr)
        r = subprocess.run([sys.executable, "-m", "venv", str(venv)],
                           stdout=sys.stderr, stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            last = (r.stderr.strip().splitlines() or ["python -m venv failed"])[-1]
            fail(f"cannot make a venv at {venv}: {last}")
    r = subprocess.run([str(py), "-c", "import vtkmodules, numpy"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        r = subprocess.run([str(py), "-m", "pip", "install", "-q", "vtk", "numpy"],
                           stdout=sys.stderr, stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            lines = [l for l in r.stderr.strip().splitlines() if l.strip()]
            why = lines[-1] if lines else "pip failed"
            fail(f"no vtk wheel for Python {sys.version.split()[0]} here "
                 f"(pip install vtk numpy into {venv}): {why}")
    env = dict(os.environ, ERCUBE_PEER_IN_VENV="1")
    os.execve(str(py), [str(py), str(Path(__file__).resolve())] + argv, env)


# ---------------------------------------------------------------- inputs


def parse_vec3(s):
    p = [float(t) for t in s.split(",")]
    if len(p) != 3:
        raise argparse.ArgumentTypeError(f"'{s}' is not x,y,z")
    return p


def parse_material(s):
    try:
        v = [float(t) for t in s.split(",")]
    except ValueError:
        v = []
    if len(v) != 4 or any(not (x >= 0.0) for x in v):
        raise argparse.ArgumentTypeError(f"'{s}' is not ka,kd,ks,shininess (four numbers >= 0)")
    return tuple(v)


def parse_size(s):
    w, h = s.lower().split("x")
    return int(w), int(h)


def load_volume(a):
    """Voxels as a numpy array indexed [z, y, x], and the spacing."""
    import numpy as np

    path = Path(a.volume)
    if a.raw_dims:
        dims = [int(t) for t in a.raw_dims.split(",")]
        dtype = {"u8": np.uint8, "u16le": "<u2", "u16be": ">u2"}[a.raw_type]
        n = dims[0] * dims[1] * dims[2]
        data = np.fromfile(path, dtype=dtype, count=n, offset=a.raw_offset)
        if data.size != n:
            fail(f"{path}: {data.size} voxels, {n} expected for {dims}")
        vol = data.astype(np.uint16 if a.raw_type != "u8" else np.uint8)
        vol = vol.reshape(dims[2], dims[1], dims[0])
        spacing = [1.0, 1.0, 1.0]
    elif path.suffix == ".den":
        # VolPack: version (i16), eight i16 triples, map_len (the ninth
        # triple, the dimensions), map_length (i32); then u8 voxels.
        raw = path.read_bytes()
        if len(raw) < DEN_HEADER:
            fail(f"{path}: truncated .den header")
        order = "<" if int.from_bytes(raw[0:2], "little") == 1 else ">"
        hdr = np.frombuffer(raw[:DEN_HEADER - 4], dtype=order + "i2")
        dims = [int(v) for v in hdr[1 + 8 * 3:1 + 9 * 3]]
        vol = np.frombuffer(raw, dtype=np.uint8, offset=DEN_HEADER)
        if vol.size != dims[0] * dims[1] * dims[2]:
            fail(f"{path}: {vol.size} voxels, header says {dims}")
        vol = vol.reshape(dims[2], dims[1], dims[0])
        spacing = [1.0, 1.0, 1.0]
    elif path.suffix == ".npy":
        vol = np.load(path)  # [z, y, x], uint8 or uint16
        spacing = [1.0, 1.0, 1.0]
    else:
        fail(f"{path}: give --raw-dims for raw files (or a .den / .npy)")
    if a.spacing:
        spacing = a.spacing
    return np.ascontiguousarray(vol), spacing


def load_tf(a):
    """Control points [(value, (r, g, b, a)), ...] as ercube's TOML has them."""
    if a.tf_file:
        import tomllib

        with open(a.tf_file, "rb") as f:
            pts = tomllib.load(f)["point"]
        return [(float(p["value"]), [float(c) for c in p["rgba"]]) for p in pts]
    # ercube's grey-ramp preset: grey value/255, opacity 0 up to 30, 1 from 150.
    return [(v, [v / 255.0] * 3 + [a]) for v, a in ((0.0, 0.0), (30.0, 0.0), (150.0, 1.0), (255.0, 1.0))]


# ---------------------------------------------------------------- render


def render(a, vol, spacing, tf):
    """Returns (image float32 HxWx4 row 0 at top, frame times, backend)."""
    import numpy as np
    from vtkmodules.util import numpy_support
    import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401  (factories)
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401
    from vtkmodules.vtkCommonCore import vtkFloatArray
    from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPiecewiseFunction
    from vtkmodules.vtkRenderingCore import (vtkColorTransferFunction, vtkRenderer,
                                             vtkRenderWindow, vtkVolume,
                                             vtkVolumeProperty)
    from vtkmodules.vtkRenderingVolume import vtkFixedPointVolumeRayCastMapper

    nz, ny, nx = vol.shape
    pad = 0 if a.no_pad else 1
    if pad:
        vol = np.pad(vol, 1, mode="edge")
    img = vtkImageData()
    img.SetDimensions(nx + 2 * pad, ny + 2 * pad, nz + 2 * pad)
    img.SetSpacing(*spacing)
    img.SetOrigin(*[-pad * s for s in spacing])
    arr = numpy_support.numpy_to_vtk(vol.ravel(order="C"), deep=True)
    img.GetPointData().SetScalars(arr)

    color = vtkColorTransferFunction()
    opacity = vtkPiecewiseFunction()
    last = None
    for value, rgba in tf:
        # VTK keeps one point per value: a step (two points at one value)
        # becomes a ramp 1e-4 scalar units wide.
        v = value if last is None or value > last else last + 1e-4
        color.AddRGBPoint(v, *rgba[:3])
        opacity.AddPoint(v, rgba[3])
        last = v
    color.ClampingOn()
    opacity.ClampingOn()
    prop = vtkVolumeProperty()
    prop.SetColor(color)
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(1.0)
    prop.SetInterpolationTypeToLinear()
    if a.shade:
        # ercube's Blinn-Phong material (golden::shading): VTK's volume
        # shading adds the specular term uncoloured and lights both sides,
        # as ercube does.
        ka, kd, ks, p = a.material
        prop.ShadeOn()
        prop.SetAmbient(ka)
        prop.SetDiffuse(kd)
        prop.SetSpecular(ks)
        prop.SetSpecularPower(p)
    else:
        prop.ShadeOff()

    mapper = vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(img)
    mapper.SetBlendModeToComposite()
    mapper.AutoAdjustSampleDistancesOff()
    mapper.LockSampleDistanceToInputSpacingOff()
    mapper.SetSampleDistance(a.sample_distance)
    mapper.SetImageSampleDistance(1.0)
    mapper.SetNumberOfThreads(a.threads)
    if pad:
        b = [(-0.5 * s, (n - 0.5) * s) for n, s in zip((nx, ny, nz), spacing)]
        mapper.CroppingOn()
        mapper.SetCroppingRegionPlanes(b[0][0], b[0][1], b[1][0], b[1][1], b[2][0], b[2][1])
        mapper.SetCroppingRegionFlagsToSubVolume()

    volume = vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)

    w, h = a.size
    ren = vtkRenderer()
    ren.SetBackground(0.0, 0.0, 0.0)
    ren.AddVolume(volume)
    win = vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.SetMultiSamples(0)
    win.SetAlphaBitPlanes(1)
    win.SetSize(w, h)
    win.AddRenderer(ren)

    cam = ren.GetActiveCamera()
    cam.SetPosition(*a.eye)
    cam.SetFocalPoint(*a.look_at)
    cam.SetViewUp(*a.up)
    cam.OrthogonalizeViewUp()
    cam.SetViewAngle(a.fov)
    cam.UseHorizontalViewAngleOff()
    ren.ResetCameraClippingRange()
    if a.shade and a.light:
        # Directional lights towards the given world directions; without
        # them VTK's automatic headlight (from the focal point towards the
        # eye) is ercube's headlight when the camera looks at the volume's
        # centre.
        from vtkmodules.vtkRenderingCore import vtkLight
        ren.AutomaticLightCreationOff()
        ren.RemoveAllLights()
        for d in a.light:
            light = vtkLight()
            light.SetLightTypeToSceneLight()
            light.SetPositional(False)
            light.SetFocalPoint(*a.look_at)
            light.SetPosition(*[f + v for f, v in zip(a.look_at, d)])
            light.SetColor(1.0, 1.0, 1.0)
            light.SetIntensity(1.0)
            ren.AddLight(light)

    win.Render()  # warm-up (also builds the mapper's tables)
    # Two clocks per frame: the mapper's own GetTimeToDraw (its ray casting
    # and compositing into the image, without the window's blit and swap:
    # the same work ercube's frame time covers) and the wall clock around
    # Render() (with them).
    times, wall = [], []
    for _ in range(a.frames):
        t = time.perf_counter()
        win.Render()
        wall.append(time.perf_counter() - t)
        times.append(float(mapper.GetTimeToDraw()))
    fa = vtkFloatArray()
    win.GetRGBAPixelData(0, 0, w - 1, h - 1, 0, fa)
    pix = numpy_support.vtk_to_numpy(fa).astype(np.float32).reshape(h, w, 4)
    pix = np.ascontiguousarray(pix[::-1])  # VTK's row 0 is the bottom
    return pix, (times, wall), win.GetClassName()


def error_against(img, ref_path):
    import numpy as np

    ref = np.load(ref_path).astype(np.float64)
    if ref.shape != img.shape:
        fail(f"--ref {ref_path} is {ref.shape}, the image {img.shape}")
    d = img[..., :3].astype(np.float64) - ref[..., :3]
    to8 = lambda x: np.clip(np.round(np.clip(x, 0, 1) * 255), 0, 255).astype(np.int32)
    mx = int(np.abs(to8(img[..., :3]) - to8(ref[..., :3])).max())
    return {"rmse": float(np.sqrt((d * d).mean())), "max_abs_255": mx}


def write_png(path, img):
    """8-bit RGB PNG with only the standard library."""
    import struct
    import zlib

    import numpy as np

    h, w, _ = img.shape
    rgb = np.clip(np.round(np.clip(img[..., :3], 0, 1) * 255), 0, 255).astype(np.uint8)
    raw = b"".join(b"\x00" + rgb[j].tobytes() for j in range(h))

    def chunk(kind, data):
        c = kind + data
        return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
    Path(path).write_bytes(png)


# ---------------------------------------------------------------- self-test


def expected_pixel(p, eye, look, up, fov, w, h):
    """Where ercube's camera model (README, "Conventions") puts point p."""
    import numpy as np

    eye, p = np.array(eye, float), np.array(p, float)
    f = np.array(look, float) - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    d = p - eye
    t = np.tan(np.radians(fov) / 2)
    sx, sy = d @ r / (d @ f), d @ u / (d @ f)
    i = (sx / (t * w / h) + 1) * w / 2 - 0.5
    j = (1 - sy / t) * h / 2 - 0.5
    return i, j


def centroid(img):
    import numpy as np

    lum = img[..., :3].sum(axis=2)
    if lum.sum() <= 0:
        return None
    jj, ii = np.mgrid[0:lum.shape[0], 0:lum.shape[1]]
    return float((ii * lum).sum() / lum.sum()), float((jj * lum).sum() / lum.sum())


def self_test(a):
    import numpy as np

    n = 24
    vox = (17, 7, 12)  # high x, low y: left of centre and low in the image
    vol = np.zeros((n, n, n), np.uint8)
    vol[vox[2], vox[1], vox[0]] = 255
    a.eye, a.look_at, a.up, a.fov, a.size = [11.5, 11.5, -24.0], [11.5, 11.5, 11.5], [0, 1, 0], 60.0, (64, 64)
    a.frames = 1
    img, _, backend = render(a, vol, [1.0, 1.0, 1.0], load_tf(a))
    c = centroid(img)
    want = expected_pixel(vox, a.eye, a.look_at, a.up, a.fov, *a.size)
    ok = c is not None and abs(c[0] - want[0]) < 0.75 and abs(c[1] - want[1]) < 0.75
    out = {"self_test": "pass" if ok else "fail", "backend": backend,
           "voxel": list(vox), "expected_pixel": list(want), "vtk_centroid": c}
    print(json.dumps(out))
    if not ok:
        fail(f"self-test: the bright voxel {vox} lands at {c}, ercube's camera puts it at {want}")


# ---------------------------------------------------------------- main


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--volume", help=".den, .npy ([z, y, x] u8/u16) or raw with --raw-dims")
    p.add_argument("--raw-dims")
    p.add_argument("--raw-type", default="u8", choices=["u8", "u16le", "u16be"])
    p.add_argument("--raw-offset", type=int, default=0)
    p.add_argument("--spacing", type=parse_vec3)
    p.add_argument("--eye", type=parse_vec3)
    p.add_argument("--look-at", type=parse_vec3, help="default: the volume centre")
    p.add_argument("--up", type=parse_vec3, default=[0.0, 1.0, 0.0])
    p.add_argument("--fov", type=float, default=60.0)
    p.add_argument("--size", type=parse_size, default=(256, 256))
    p.add_argument("--tf-file", help="ercube TOML control points (default: grey-ramp)")
    p.add_argument("--frames", type=int, default=5, help="timed frames after one warm-up")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--sample-distance", type=float, default=0.5, help="world units")
    p.add_argument("--no-pad", action="store_true",
                   help="render VTK's own bounds (voxel centres) instead of ercube's cell faces")
    p.add_argument("--npy", help="write the image, float32 HxWx4")
    p.add_argument("--png", help="write the image as 8-bit RGB PNG")
    p.add_argument("--ref", help="ercube reference .npy to report RMSE against")
    p.add_argument("--self-test", action="store_true")
    p.add_argument("--shade", action="store_true",
                   help="Blinn-Phong shading (ShadeOn) with --material and --light")
    p.add_argument("--material", type=parse_material, default=(0.1, 0.7, 0.2, 10.0),
                   help="ka,kd,ks,shininess (default VTK's and ercube's 0.1,0.7,0.2,10)")
    p.add_argument("--light", type=parse_vec3, action="append", default=[],
                   help="directional light towards world dx,dy,dz (repeatable; default: headlight)")
    a = p.parse_args(argv)
    ensure_vtk(argv)
    import numpy as np

    if a.self_test:
        return self_test(a)
    if not a.volume:
        fail("no --volume")
    if a.frames < 1:
        fail("--frames must be at least 1")
    vol, spacing = load_volume(a)
    nz, ny, nx = vol.shape
    centre = [(n - 1) * s / 2 for n, s in zip((nx, ny, nz), spacing)]
    if a.look_at is None:
        a.look_at = centre
    if a.eye is None:
        depth = max(n * s for n, s in zip((nx, ny, nz), spacing))
        a.eye = [centre[0], centre[1], -1.5 * depth]
    img, (times, wall), backend = render(a, vol, spacing, load_tf(a))
    import vtkmodules

    out = {"peer": "vtk", "vtk_version": vtkmodules.__version__, "backend": backend,
           "mapper": "vtkFixedPointVolumeRayCastMapper", "threads": a.threads,
           "sample_distance": a.sample_distance, "padded": not a.no_pad,
           "size": list(a.size), "frames": a.frames,
           "timer": "mapper GetTimeToDraw",
           "time_s": float(np.median(times)), "times_s": times,
           "wall_time_s": float(np.median(wall)), "wall_times_s": wall}
    if a.npy:
        np.save(a.npy, img)
        out["image"] = a.npy
    if a.png:
        write_png(a.png, img)
        out["png"] = a.png
    if a.ref:
        out["error_vs_reference"] = error_against(img, a.ref)
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1:])
