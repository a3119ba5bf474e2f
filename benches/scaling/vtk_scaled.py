"""VTK's side of benches/scaling.sh: the peer scene of ../shared/bench/vtk_dvr.py on any .vlb
volume (8 or 16 bit), read from the file's voxels (after its 28-byte header) without a copy on
disk. The volume is taken as the MNI template at S = (ny - 1) / 232 voxels per mm: spacing 1/S
mm, so the camera (360 mm from the centre) and the opacity unit distance (1 mm) are the
template's, and the sample distance is STEP voxels (STEP / S mm). The transfer functions are
vtk_dvr's on the normalised scale: their 0..255 points times (b - a) / 255, plus a.

    python3 vtk_scaled.py VOLUME.vlb JSON [--frames N] [--step 0.5] [--size 512]
"""
import json
import os
import struct
import sys

sys.path.insert(0, os.environ.get("VLIB_SHARED_BENCH", os.path.join(os.path.dirname(__file__), "../../../shared/bench")))
import numpy as np  # noqa: E402
import vtk  # noqa: E402
from vtk.util import numpy_support  # noqa: E402
import vtk_dvr  # noqa: E402


def main():
    args = sys.argv[1:]
    vlb, out = args[0], args[1]
    opt = dict(zip(args[2::2], args[3::2]))
    frames, step, size = int(opt.get("--frames", 2)), float(opt.get("--step", 0.5)), int(opt.get("--size", 512))
    with open(vlb, "rb") as f:
        head = f.read(28)
    assert head[:4] == b"VLB1", vlb
    X, Y, Z, width = struct.unpack("<4I", head[4:20])
    a, b = struct.unpack("<2f", head[20:28])
    dtype = "uint8" if width == 1 else "uint16"
    scale = (Y - 1) / 232.0

    def load_volume(_dtype):
        arr = np.fromfile(vlb, dtype="<u1" if width == 1 else "<u2", offset=28)
        assert arr.size == X * Y * Z
        img = vtk.vtkImageData()
        img.SetDimensions(X, Y, Z)
        img.SetSpacing(1 / scale, 1 / scale, 1 / scale)
        img.SetOrigin(0, 0, 0)
        va = numpy_support.numpy_to_vtk(arr, deep=False,
                                        array_type=vtk.VTK_UNSIGNED_CHAR if width == 1 else vtk.VTK_UNSIGNED_SHORT)
        va.SetName("T1")
        img.GetPointData().SetScalars(va)
        img._keep = arr  # the array backs the VTK array (no deep copy)
        return img, {"dims": [X, Y, Z], "spacing_mm": [1 / scale] * 3}

    plain = vtk_dvr.make_property

    def make_property(_dtype, shade):
        # vtk_dvr scales 0..255 points by 1 (uint8) or 257 (uint16); here by (b - a) / 255 + a.
        prop = plain("uint8", shade)
        otf, ctf = prop.GetScalarOpacity(), prop.GetRGBTransferFunction()
        otf.RemoveAllPoints()
        ctf.RemoveAllPoints()
        k = (b - a) / 255.0
        for s, o in vtk_dvr.OPACITY_POINTS:
            otf.AddPoint(a + s * k, o)
        for s, r, g, bl in vtk_dvr.COLOR_POINTS:
            ctf.AddRGBPoint(a + s * k, r, g, bl)
        return prop

    vtk_dvr.WORK = os.path.dirname(os.path.abspath(out))
    vtk_dvr.load_volume = load_volume
    vtk_dvr.make_property = make_property
    vtk_dvr.CONFIGS = {"scaled": ("fixed", dtype, True, step / scale, None)}
    sys.argv = [sys.argv[0], "--only", "scaled", "--frames", str(frames), "--size", str(size), "--json", out]
    vtk_dvr.main()


if __name__ == "__main__":
    main()
