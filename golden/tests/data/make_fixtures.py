#!/usr/bin/env python3
"""Writes the loader fixtures of golden/tests/data with independent writers.

Every fixture holds the same synthetic 12x10x7 volume (x fastest), computed
by the formulas below; golden/tests/formats.rs computes the same formulas in
Rust and checks that every file loads to the same voxels.

    u8:  (7x + 13y + 29z + xy) mod 256
    u16: (1000x + 300y + 5000z + 17xyz) mod 65536
    i16: floor(u16 formula / 2) - 16000            (negative values)
    f32: (x - 2y + 0.5z) * 0.25                    (exact in binary)

Spacing (0.5, 0.75, 1.25), origin (-3, 2.5, 10), identity directions,
where the format carries them (TIFF does not: spacing 1).

Writers: pynrrd (NRRD), SimpleITK (MetaImage), tifffile (TIFF), nibabel
(NIfTI-1). Run from anywhere, in a venv holding them:

    python3 -m venv /tmp/venv && /tmp/venv/bin/pip install \
        pynrrd SimpleITK tifffile numpy nibabel
    /tmp/venv/bin/python golden/tests/data/make_fixtures.py
"""

import os
import shutil

import nibabel as nib
import nrrd
import numpy as np
import SimpleITK as sitk
import tifffile

OUT = os.path.dirname(os.path.abspath(__file__))
NX, NY, NZ = 12, 10, 7
SPACING = (0.5, 0.75, 1.25)
ORIGIN = (-3.0, 2.5, 10.0)


def volume(kind):
    """The synthetic volume as a (z, y, x) array, so C order is x fastest."""
    z, y, x = np.meshgrid(np.arange(NZ), np.arange(NY), np.arange(NX), indexing="ij")
    if kind == "u8":
        return ((7 * x + 13 * y + 29 * z + x * y) % 256).astype(np.uint8)
    u16 = (1000 * x + 300 * y + 5000 * z + 17 * x * y * z) % 65536
    if kind == "u16":
        return u16.astype(np.uint16)
    if kind == "i16":
        return (u16 // 2 - 16000).astype(np.int16)
    if kind == "f32":
        return ((x - 2 * y + 0.5 * z) * 0.25).astype(np.float32)
    raise ValueError(kind)


def path(name):
    return os.path.join(OUT, name)


def write_nrrd(kind, arr):
    header = {
        "space": "left-posterior-superior",
        "space directions": np.diag(SPACING),
        "space origin": np.array(ORIGIN),
        "encoding": "raw",
    }
    nrrd.write(path(f"vol_{kind}.nrrd"), arr, dict(header), index_order="C")
    nrrd.write(
        path(f"vol_{kind}_gz.nrrd"), arr, dict(header, encoding="gzip"), index_order="C"
    )
    # Detached headers: pynrrd writes the .nhdr and its data file beside it
    # (vol_*_det.raw, vol_*_detgz.raw.gz).
    nrrd.write(
        path(f"vol_{kind}_det.nhdr"), arr, dict(header), detached_header=True,
        index_order="C",
    )
    nrrd.write(
        path(f"vol_{kind}_detgz.nhdr"), arr, dict(header, encoding="gzip"),
        detached_header=True, index_order="C",
    )
    # Big-endian data, per-axis spacings instead of space directions.
    big = {"spacings": np.array(SPACING), "encoding": "raw"}
    nrrd.write(
        path(f"vol_{kind}_be.nrrd"), arr.astype(arr.dtype.newbyteorder(">")), big,
        index_order="C",
    )


def write_meta(kind, arr):
    img = sitk.GetImageFromArray(arr)
    img.SetSpacing(SPACING)
    img.SetOrigin(ORIGIN)
    sitk.WriteImage(img, path(f"vol_{kind}.mha"), useCompression=False)
    sitk.WriteImage(img, path(f"vol_{kind}.mhd"), useCompression=False)
    sitk.WriteImage(img, path(f"vol_{kind}_z.mhd"), useCompression=True)


def write_tiff(kind, arr):
    tifffile.imwrite(path(f"vol_{kind}.tif"), arr, photometric="minisblack")
    folder = path(f"vol_{kind}_pages")
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(folder)
    for z in range(NZ):
        tifffile.imwrite(
            os.path.join(folder, f"slice_{z:03d}.tif"), arr[z], photometric="minisblack"
        )


def write_nifti(kind, arr):
    affine = np.diag(list(SPACING) + [1.0])
    affine[:3, 3] = ORIGIN
    img = nib.Nifti1Image(np.ascontiguousarray(arr.transpose(2, 1, 0)), affine)
    img.header.set_data_dtype(arr.dtype)
    nib.save(img, path(f"vol_{kind}.nii"))


def main():
    for name in os.listdir(OUT):
        if name.startswith("vol_"):
            p = path(name)
            shutil.rmtree(p) if os.path.isdir(p) else os.remove(p)
    for kind in ["u8", "u16", "i16", "f32"]:
        arr = volume(kind)
        write_nrrd(kind, arr)
        write_meta(kind, arr)
        write_nifti(kind, arr)
        if kind in ("u8", "u16"):
            write_tiff(kind, arr)
    for root, _, files in os.walk(OUT):
        for f in files:
            size = os.path.getsize(os.path.join(root, f))
            assert size < 20_000, (f, size)


if __name__ == "__main__":
    main()
