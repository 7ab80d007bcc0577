#!/usr/bin/env python3
"""Writes the orientation fixtures of golden/tests/data: one small synthetic
head, CT-like (air -1000, brain 40, skull 1000, a nose in front, an ear on
the patient's left), stored by four tools in four different orientations.
Placed in patient space each is the same head, so the loaders, after
`--space world` puts them on the world axes, must give identical volumes
and identical renders (golden/tests/it/orientation.rs).

The head is defined on an LPS-aligned grid (x = left, y = posterior,
z = superior): 14 x 16 x 12 voxels, spacing (1, 1.5, 2) mm, voxel (0,0,0)
at (-6.5, -11.25, -11). Each file's index axis k runs along world axis
AXES[k] with sign SIGNS[k]:

    head_ras.nii   nibabel     i -> R, j -> A, k -> S (x and y flipped: RAS)
    head_perm.nrrd pynrrd      i -> I, j -> L, k -> P (LPS space)
    head_perm.mha  SimpleITK   i -> P, j -> I, k -> R
    head_coronal/  pydicom     coronal slices: rows along L, columns along
                               I, slices along P; int16 stored HU + 1024
                               with RescaleIntercept -1024; shuffled names

Run in a venv holding the writers:

    python3 -m venv /tmp/venv && /tmp/venv/bin/pip install \
        pydicom pynrrd SimpleITK nibabel numpy
    /tmp/venv/bin/python golden/tests/data/make_oriented.py
"""

import os
import random
import shutil

import nibabel as nib
import nrrd
import numpy as np
import SimpleITK as sitk
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

OUT = os.path.dirname(os.path.abspath(__file__))
DIMS = (14, 16, 12)
SPACING = (1.0, 1.5, 2.0)
ORIGIN = (-6.5, -11.25, -11.0)


def head():
    """The head as A[x, y, z] on the LPS grid, int16 HU."""
    x, y, z = np.meshgrid(*[np.arange(n) for n in DIMS], indexing="ij")
    px = ORIGIN[0] + SPACING[0] * x
    py = ORIGIN[1] + SPACING[1] * y
    pz = ORIGIN[2] + SPACING[2] * z
    v = np.full(DIMS, -1000, dtype=np.int16)
    r = np.sqrt((px / 6.0) ** 2 + (py / 10.0) ** 2 + (pz / 10.0) ** 2)
    v[r < 1.0] = 1000
    v[r < 0.8] = 40
    nose = (px / 2.0) ** 2 + ((py + 10.0) / 2.5) ** 2 + ((pz + 2.0) / 3.0) ** 2 < 1.0
    v[nose] = 60
    ear = ((px - 6.0) / 1.5) ** 2 + (py / 2.5) ** 2 + (pz / 3.0) ** 2 < 1.0
    v[ear] = 200
    return v


def oriented(a, axes, signs):
    """The array indexed by file axes, the file spacing, origin (LPS) and
    unit directions (LPS, one per file axis)."""
    d = a.transpose(axes)
    for k, s in enumerate(signs):
        if s < 0:
            d = np.flip(d, axis=k)
    origin = np.array(ORIGIN)
    dirs = np.zeros((3, 3))
    for k, (w, s) in enumerate(zip(axes, signs)):
        dirs[k, w] = s
        if s < 0:
            origin[w] += SPACING[w] * (DIMS[w] - 1)
    spacing = np.array([SPACING[w] for w in axes])
    return np.ascontiguousarray(d), spacing, origin, dirs


def write_nifti(a):
    d, sp, o, dirs = oriented(a, (0, 1, 2), (-1, -1, 1))
    ras = np.diag([-1.0, -1.0, 1.0])
    affine = np.eye(4)
    affine[:3, :3] = ras @ (dirs.T * sp)
    affine[:3, 3] = ras @ o
    img = nib.Nifti1Image(d, affine)
    img.header.set_data_dtype(np.int16)
    nib.save(img, os.path.join(OUT, "head_ras.nii"))


def write_nrrd(a):
    d, sp, o, dirs = oriented(a, (2, 0, 1), (-1, 1, 1))
    header = {
        "space": "left-posterior-superior",
        "space directions": dirs * sp[:, None],
        "space origin": o,
        "encoding": "gzip",
    }
    nrrd.write(os.path.join(OUT, "head_perm.nrrd"), d, header, index_order="F")


def write_meta(a):
    d, sp, o, dirs = oriented(a, (1, 2, 0), (1, -1, -1))
    img = sitk.GetImageFromArray(d.transpose(2, 1, 0))
    img.SetSpacing(sp.tolist())
    img.SetOrigin(o.tolist())
    # ITK's direction matrix has the axis directions as columns.
    img.SetDirection(dirs.T.flatten().tolist())
    sitk.WriteImage(img, os.path.join(OUT, "head_perm.mha"), useCompression=True)


def write_dicom(a):
    d, sp, o, dirs = oriented(a, (0, 2, 1), (1, -1, 1))
    assert np.allclose(np.cross(dirs[0], dirs[1]), dirs[2])
    folder = os.path.join(OUT, "head_coronal")
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(folder)
    study, series = generate_uid(), generate_uid()
    n = d.shape[2]
    names = [f"{k:08x}.dcm" for k in random.Random(7).sample(range(1 << 28), n)]
    for k in range(n):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = Dataset()
        ds.file_meta = meta
        ds.SOPClassUID = meta.MediaStorageSOPClassUID
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.Modality = "CT"
        ds.StudyInstanceUID, ds.SeriesInstanceUID = study, series
        ds.InstanceNumber = k + 1
        ds.ImageOrientationPatient = [float(c) for c in np.concatenate([dirs[0], dirs[1]])]
        ds.ImagePositionPatient = [float(c) for c in o + k * sp[2] * dirs[2]]
        ds.PixelSpacing = [float(sp[1]), float(sp[0])]
        plane = np.ascontiguousarray((d[:, :, k].T.astype(np.int32) + 1024).astype(np.int16))
        ds.Rows, ds.Columns = plane.shape
        ds.SamplesPerPixel = 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        ds.BitsAllocated = ds.BitsStored = 16
        ds.HighBit = 15
        ds.PixelRepresentation = 1
        ds.RescaleSlope, ds.RescaleIntercept = 1, -1024
        ds.PixelData = plane.tobytes()
        ds.save_as(os.path.join(folder, names[k]), enforce_file_format=True)


def main():
    a = head()
    write_nifti(a)
    write_nrrd(a)
    write_meta(a)
    write_dicom(a)
    for root, _, files in os.walk(OUT):
        for f in files:
            size = os.path.getsize(os.path.join(root, f))
            assert size < 20_000, (f, size)


if __name__ == "__main__":
    main()
