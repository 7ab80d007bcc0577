#!/usr/bin/env python3
"""Writes the DICOM series fixtures of golden/tests/data with pydicom.

Each series is a folder of single-frame slices holding the synthetic
12x10x7 volume of make_fixtures.py (same formulas, spacing (0.5, 0.75,
1.25), origin (-3, 2.5, 10), identity orientation), so it must load to the
same voxels as the other formats' fixtures of its type:

    dicom_u16  uint16, explicit VR little endian, file names in shuffled order
    dicom_i16  CT-like: int16 stored values = the i16 formula + 1024 with
               RescaleIntercept -1024 (the Hounsfield units are the i16
               formula), implicit VR little endian, slices written head
               first under shuffled names
    dicom_u8   uint8, RLE lossless (pydicom's own encoder)
    dicom_f32  int16 stored values 4x - 8y + 2z with RescaleSlope 0.0625,
               so the rescaled values are the f32 formula (non-integral)
    dicom_j2k  one slice labelled JPEG 2000 (encapsulated bytes that are
               not a real codestream): a transfer syntax the loader refuses

and multi-frame objects of the same volume, one file each:

    dicom_mf_i16.dcm  Enhanced CT: the dicom_i16 stored values and rescale,
               explicit VR little endian, the geometry and rescale in the
               functional groups (shared: PixelMeasuresSequence,
               PlaneOrientationSequence, PixelValueTransformationSequence;
               per frame: PlanePositionSequence), the frames stored in
               shuffled position order
    dicom_mf_u8.dcm   plain multi-frame: the dicom_u8 values, RLE lossless,
               top-level geometry, frames stepping by SpacingBetweenSlices
    dicom_mf_badcount.dcm  plain multi-frame uint16 saying NumberOfFrames 8
               over 7 frames of pixel data: refused

Run in a venv holding pydicom and numpy:

    python3 -m venv /tmp/venv && /tmp/venv/bin/pip install pydicom numpy
    /tmp/venv/bin/python golden/tests/data/make_dicom.py [NAME ...]

(names, e.g. dicom_mf_i16.dcm, write only those fixtures).
"""

import os
import random
import shutil
import sys

import numpy as np
import pydicom
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.encaps import encapsulate
from pydicom.uid import (
    ExplicitVRLittleEndian,
    ImplicitVRLittleEndian,
    JPEG2000,
    RLELossless,
    generate_uid,
)

OUT = os.path.dirname(os.path.abspath(__file__))
NX, NY, NZ = 12, 10, 7
SPACING = (0.5, 0.75, 1.25)
ORIGIN = (-3.0, 2.5, 10.0)
CT_IMAGE = "1.2.840.10008.5.1.4.1.1.2"
MR_IMAGE = "1.2.840.10008.5.1.4.1.1.4"


def grid():
    return np.meshgrid(np.arange(NZ), np.arange(NY), np.arange(NX), indexing="ij")


def stored(kind):
    """The stored values as a (z, y, x) array."""
    z, y, x = grid()
    u16 = (1000 * x + 300 * y + 5000 * z + 17 * x * y * z) % 65536
    if kind == "u8":
        return ((7 * x + 13 * y + 29 * z + x * y) % 256).astype(np.uint8)
    if kind == "u16":
        return u16.astype(np.uint16)
    if kind == "i16":
        return (u16 // 2 - 16000 + 1024).astype(np.int16)
    if kind == "f32":
        return (4 * x - 8 * y + 2 * z).astype(np.int16)
    raise ValueError(kind)


def slice_ds(arr, k, series, syntax, sop_class, rescale):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = sop_class
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = syntax
    ds = Dataset()
    ds.file_meta = meta
    ds.SOPClassUID = sop_class
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = "CT" if sop_class == CT_IMAGE else "MR"
    ds.PatientName = "Synthetic^Fixture"
    ds.StudyInstanceUID = series[0]
    ds.SeriesInstanceUID = series[1]
    ds.InstanceNumber = k + 1
    ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
    ds.ImagePositionPatient = [ORIGIN[0], ORIGIN[1], ORIGIN[2] + SPACING[2] * k]
    # PixelSpacing is (between rows, between columns) = (y, x).
    ds.PixelSpacing = [SPACING[1], SPACING[0]]
    ds.SliceThickness = SPACING[2]
    ds.Rows, ds.Columns = arr.shape[1], arr.shape[2]
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    bits = arr.dtype.itemsize * 8
    ds.BitsAllocated = bits
    ds.BitsStored = bits
    ds.HighBit = bits - 1
    ds.PixelRepresentation = 1 if arr.dtype.kind == "i" else 0
    if rescale is not None:
        ds.RescaleSlope, ds.RescaleIntercept = rescale
    plane = np.ascontiguousarray(arr[k])
    if syntax == RLELossless:
        ds.file_meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds.PixelData = plane.tobytes()
        ds.compress(RLELossless, plane)
    elif syntax == JPEG2000:
        ds.PixelData = encapsulate([b"\xff\x4f\xff\x51" + bytes(28)])
        ds["PixelData"].VR = "OB"
    else:
        ds.PixelData = plane.tobytes()
    return ds


def write_series(name, kind, syntax, sop_class, rescale, head_first=False, count=NZ):
    folder = os.path.join(OUT, name)
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(folder)
    arr = stored(kind)
    series = (generate_uid(), generate_uid())
    order = list(range(count))
    if head_first:
        order.reverse()
    names = [f"IM{n:04d}" for n in random.Random(name).sample(range(1000, 9999), count)]
    for i, k in enumerate(order):
        ds = slice_ds(arr, k, series, syntax, sop_class, rescale)
        ds.save_as(os.path.join(folder, names[i]), enforce_file_format=True)


ENHANCED_CT = "1.2.840.10008.5.1.4.1.1.2.1"
MULTIFRAME_BYTE_SC = "1.2.840.10008.5.1.4.1.1.7.2"
MULTIFRAME_WORD_SC = "1.2.840.10008.5.1.4.1.1.7.3"


def item(**attrs):
    ds = Dataset()
    for k, v in attrs.items():
        setattr(ds, k, v)
    return ds


def multiframe_ds(arr, sop_class, syntax):
    """A multi-frame object's common attributes (no geometry)."""
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = sop_class
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = syntax
    ds = Dataset()
    ds.file_meta = meta
    ds.SOPClassUID = sop_class
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = "CT" if sop_class == ENHANCED_CT else "OT"
    ds.PatientName = "Synthetic^Fixture"
    ds.StudyInstanceUID = generate_uid()
    ds.SeriesInstanceUID = generate_uid()
    ds.InstanceNumber = 1
    ds.NumberOfFrames = arr.shape[0]
    ds.Rows, ds.Columns = arr.shape[1], arr.shape[2]
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    bits = arr.dtype.itemsize * 8
    ds.BitsAllocated = bits
    ds.BitsStored = bits
    ds.HighBit = bits - 1
    ds.PixelRepresentation = 1 if arr.dtype.kind == "i" else 0
    return ds


def write_enhanced_ct(name):
    """dicom_i16's slices as the frames of one Enhanced CT object, stored
    in shuffled position order, each placed by its PlanePositionSequence."""
    arr = stored("i16")
    order = random.Random(name).sample(range(NZ), NZ)
    ds = multiframe_ds(arr[order], ENHANCED_CT, ExplicitVRLittleEndian)
    ds.SharedFunctionalGroupsSequence = [
        item(
            PixelMeasuresSequence=[
                item(
                    PixelSpacing=[SPACING[1], SPACING[0]],
                    SliceThickness=SPACING[2],
                    SpacingBetweenSlices=SPACING[2],
                )
            ],
            PlaneOrientationSequence=[item(ImageOrientationPatient=[1, 0, 0, 0, 1, 0])],
            PixelValueTransformationSequence=[
                item(RescaleIntercept=-1024, RescaleSlope=1, RescaleType="HU")
            ],
        )
    ]
    ds.PerFrameFunctionalGroupsSequence = [
        item(
            FrameContentSequence=[item(InStackPositionNumber=k + 1)],
            PlanePositionSequence=[
                item(ImagePositionPatient=[ORIGIN[0], ORIGIN[1], ORIGIN[2] + SPACING[2] * k])
            ],
        )
        for k in order
    ]
    ds.PixelData = np.ascontiguousarray(arr[order]).tobytes()
    ds.save_as(os.path.join(OUT, name), enforce_file_format=True)


def plain_multiframe(arr, sop_class, syntax):
    """A plain multi-frame object, its geometry at the top level."""
    ds = multiframe_ds(arr, sop_class, syntax)
    ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
    ds.ImagePositionPatient = list(ORIGIN)
    ds.PixelSpacing = [SPACING[1], SPACING[0]]
    ds.SliceThickness = SPACING[2]
    ds.SpacingBetweenSlices = SPACING[2]
    return ds


def write_plain_u8(name):
    arr = stored("u8")
    ds = plain_multiframe(arr, MULTIFRAME_BYTE_SC, ExplicitVRLittleEndian)
    ds.PixelData = arr.tobytes()
    ds.compress(RLELossless, arr)
    ds.save_as(os.path.join(OUT, name), enforce_file_format=True)


def write_bad_count(name):
    arr = stored("u16")
    ds = plain_multiframe(arr, MULTIFRAME_WORD_SC, ExplicitVRLittleEndian)
    ds.PixelData = arr.tobytes()
    ds.NumberOfFrames = NZ + 1
    ds.save_as(os.path.join(OUT, name), enforce_file_format=True)


def main():
    fixtures = {
        "dicom_u16": lambda: write_series(
            "dicom_u16", "u16", ExplicitVRLittleEndian, MR_IMAGE, None
        ),
        "dicom_i16": lambda: write_series(
            "dicom_i16", "i16", ImplicitVRLittleEndian, CT_IMAGE, (1, -1024), head_first=True
        ),
        "dicom_u8": lambda: write_series("dicom_u8", "u8", RLELossless, MR_IMAGE, None),
        "dicom_f32": lambda: write_series(
            "dicom_f32", "f32", ExplicitVRLittleEndian, CT_IMAGE, (0.0625, 0)
        ),
        "dicom_j2k": lambda: write_series("dicom_j2k", "u8", JPEG2000, MR_IMAGE, None, count=1),
        "dicom_mf_i16.dcm": lambda: write_enhanced_ct("dicom_mf_i16.dcm"),
        "dicom_mf_u8.dcm": lambda: write_plain_u8("dicom_mf_u8.dcm"),
        "dicom_mf_badcount.dcm": lambda: write_bad_count("dicom_mf_badcount.dcm"),
    }
    for name in sys.argv[1:] or fixtures:
        fixtures[name]()
    for root, _, files in os.walk(OUT):
        for f in files:
            size = os.path.getsize(os.path.join(root, f))
            assert size < 20_000, (f, size)


if __name__ == "__main__":
    main()
