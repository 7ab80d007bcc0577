//! Single-file NIfTI-1 volumes (`.nii`, `.nii.gz`).

use std::io::{BufRead, BufReader, ErrorKind, Read};
use std::path::Path;

use super::decode::{drain, read_scalars, Scalar};
use super::{check_spacing, data_err, format_err, from_file, io_err, open, unit_axes, Loaded};
use crate::error::{Error, Result};
use crate::volume::{check_dims, Volume};

/// Size of a NIfTI-1 header; the voxel data of a `.nii` starts at or after
/// byte 352 (header plus the 4-byte extension flag).
const NIFTI_HEADER: u64 = 348;

const NIFTI_TYPES: &str = "use uint8, int16, uint16 or float32";

/// Loads a single-file NIfTI-1 volume (`.nii`, or gzip-compressed
/// `.nii.gz`; compression is detected from the gzip magic bytes, not the
/// name).
///
/// The header is parsed with the `nifti` crate and checked first (3D only:
/// `dim[0] == 3`, or up to 7 with every extra dimension 1; each edge within
/// [`check_dims`]; `bitpix` agreeing with the datatype; `vox_offset` at or
/// past byte 352); only then is the voxel buffer allocated and filled by
/// streaming the data. The crate's whole-object reader is not used because
/// it allocates extension blocks sized by the file and keeps a raw byte
/// copy beside the decoded data. Trailing bytes after the voxel data are
/// accepted, since the header states the size itself. Header-only
/// `.hdr`/`.img` pairs and NIfTI-2 are refused.
///
/// Datatypes and how they become voxels (the rule every loader shares, so
/// the same data through NRRD or MetaImage gives the same volume):
/// - `uint8`: kept as is ([`VoxelType::U8`]).
/// - `uint16`: kept as is ([`VoxelType::U16`]).
/// - `int16`: kept as is when no voxel is negative; otherwise every voxel is
///   offset by minus the minimum, so the minimum maps to 0 and the whole
///   range fits `u16` without clamping ([`VoxelType::U16`]).
/// - `float32`: the finite minimum..maximum is mapped linearly onto
///   0..=65535 and rounded ([`VoxelType::U16`]); NaN and infinite voxels
///   (common outside masks) become 0; a constant volume becomes all 0.
///
/// `scl_slope`/`scl_inter` are not applied: transfer functions are written
/// in stored units, a positive linear scaling only relabels the scalar axis,
/// and float data is rescaled anyway. Voxel `(i, j, k)` of the file is
/// voxel `(x, y, z)`; the orientation (qform/sform) is returned by
/// [`read_nifti`] for `--space world`, not applied here. The spacing
/// is `|pixdim[1..4]|`, in the file's units; a zero or non-finite entry is
/// taken as 1.
///
/// Memory: the limit is checked against 2 bytes per voxel (the volume), or
/// 6 for `float32`, whose voxels are held as `f32` until the range is known.
///
/// [`VoxelType::U8`]: crate::volume::VoxelType::U8
/// [`VoxelType::U16`]: crate::volume::VoxelType::U16
pub fn load_nifti(path: &Path, limit: u64) -> Result<Volume> {
    read_nifti(path, limit).map(|l| l.volume)
}

/// Reads a NIfTI-1 volume (see [`load_nifti`]) with its placement in LPS
/// world space: the sform if `sform_code > 0`, else the qform if
/// `qform_code > 0` (nibabel's and ITK's preference), else none. NIfTI
/// world space is RAS, so x and y change sign.
pub fn read_nifti(path: &Path, limit: u64) -> Result<Loaded> {
    let file = open(path)?;
    let file_bytes = super::file_len(&file, path)?;
    let mut buffered = BufReader::new(file);
    let gz = buffered
        .fill_buf()
        .map_err(|e| io_err(path, e))?
        .starts_with(&[0x1f, 0x8b]);
    let mut reader: Box<dyn Read> = if gz {
        Box::new(flate2::bufread::MultiGzDecoder::new(buffered))
    } else {
        Box::new(buffered)
    };
    let header = nifti::NiftiHeader::from_reader(&mut reader).map_err(|e| nifti_err(path, e))?;
    let fmt = |msg: String| format_err(path, msg);

    if header.sizeof_hdr != NIFTI_HEADER as i32 {
        return Err(fmt(format!(
            "sizeof_hdr is {}, not {NIFTI_HEADER}: not a NIfTI-1 file",
            header.sizeof_hdr
        )));
    }
    if &header.magic != nifti::header::MAGIC_CODE_NIP1 {
        return Err(fmt(
            "a header-only NIfTI (.hdr/.img pair) is not supported: convert it to a single .nii"
                .into(),
        ));
    }
    let ndim = header.dim[0] as usize;
    if !(3..=7).contains(&ndim) {
        return Err(fmt(format!(
            "NIfTI image has {ndim} dimensions: only 3D volumes are supported"
        )));
    }
    if let Some(k) = (4..=ndim).find(|&k| header.dim[k] != 1) {
        return Err(fmt(format!(
            "NIfTI dim[{k}] = {} (a {ndim}D image): only 3D volumes are supported",
            header.dim[k] as i16
        )));
    }
    // The spec's dims are i16; the crate reads them as u16, so a negative
    // edge shows up as a huge one and check_dims calls it absurd.
    let dims = [
        header.dim[1] as usize,
        header.dim[2] as usize,
        header.dim[3] as usize,
    ];
    let datatype = header.data_type().map_err(|_| {
        fmt(format!(
            "unknown NIfTI datatype code {}: {NIFTI_TYPES}",
            header.datatype
        ))
    })?;
    use nifti::NiftiType as T;
    let scalar = match datatype {
        T::Uint8 => Scalar::U8,
        T::Uint16 => Scalar::U16,
        T::Int16 => Scalar::I16,
        T::Float32 => Scalar::F32,
        other => {
            let code = header.datatype;
            return Err(fmt(format!(
                "unsupported NIfTI datatype {other:?} (code {code}): {NIFTI_TYPES}"
            )));
        }
    };
    let elem = scalar.bytes();
    if header.bitpix as i64 != 8 * elem as i64 {
        return Err(fmt(format!(
            "bitpix {} disagrees with datatype {datatype:?} ({} bits)",
            header.bitpix,
            8 * elem
        )));
    }
    let offset = header.vox_offset;
    if !offset.is_finite() || offset < 352.0 || offset.fract() != 0.0 || offset > 1e12 {
        return Err(fmt(format!(
            "vox_offset {offset} is not a byte offset at or after 352"
        )));
    }
    let offset = offset as u64;
    let count = check_dims(dims, scalar.peak(), limit).map_err(|e| from_file(path, e))?;
    // A plain file must hold the voxels its header promises before any is
    // allocated (a gzip stream is decoded into a buffer that grows only as
    // the data arrives).
    let total = count as u64 * elem as u64;
    let have = file_bytes.saturating_sub(offset);
    if !gz && have < total {
        return Err(fmt(format!(
            "truncated: expected {total} bytes of voxel data at offset {offset}, found {have}"
        )));
    }

    // Skip the extension flag and any extensions.
    let skip = offset - NIFTI_HEADER;
    let skipped = std::io::copy(&mut (&mut reader).take(skip), &mut std::io::sink())
        .map_err(|e| data_err(path, e))?;
    if skipped != skip {
        return Err(fmt(format!(
            "truncated: vox_offset is {offset}, file ends at byte {}",
            NIFTI_HEADER + skipped
        )));
    }

    let big = header.endianness == nifti::Endianness::Big;
    let (kind, data, units) = read_scalars(path, &mut reader, count, scalar, big, offset)?;
    if gz {
        drain(path, &mut reader)?;
    }
    let pixdim = [1, 2, 3].map(|k| header.pixdim[k] as f64);
    let spacing = check_spacing(path, "pixdim[1..4]", pixdim)?;
    let volume = Volume::new(dims, kind, data)?
        .with_spacing(spacing)?
        .with_units(units);
    let (origin, axes) = placement(&header);
    Ok(Loaded {
        volume,
        origin,
        axes,
    })
}

/// The header's placement in LPS: origin and unit axis directions.
fn placement(h: &nifti::NiftiHeader) -> (Option<[f64; 3]>, Option<[[f64; 3]; 3]>) {
    let lps = crate::orient::ras_to_lps;
    if h.sform_code > 0 {
        let rows = [h.srow_x, h.srow_y, h.srow_z].map(|r| r.map(|v| v as f64));
        let col = |k: usize| lps([rows[0][k], rows[1][k], rows[2][k]]);
        let origin = col(3);
        if origin.iter().all(|c| c.is_finite()) {
            return (Some(origin), unit_axes([col(0), col(1), col(2)]));
        }
        return (None, None);
    }
    if h.qform_code > 0 {
        let [b, c, d] = [h.quatern_b, h.quatern_c, h.quatern_d].map(|v| v as f64);
        let a = (1.0 - (b * b + c * c + d * d)).max(0.0).sqrt();
        let r = [
            [
                a * a + b * b - c * c - d * d,
                2.0 * (b * c - a * d),
                2.0 * (b * d + a * c),
            ],
            [
                2.0 * (b * c + a * d),
                a * a + c * c - b * b - d * d,
                2.0 * (c * d - a * b),
            ],
            [
                2.0 * (b * d - a * c),
                2.0 * (c * d + a * b),
                a * a + d * d - c * c - b * b,
            ],
        ];
        let qfac = if h.pixdim[0] < 0.0 { -1.0 } else { 1.0 };
        let col = |k: usize| {
            let s = if k == 2 { qfac } else { 1.0 };
            lps([r[0][k] * s, r[1][k] * s, r[2][k] * s])
        };
        let origin = lps([h.quatern_x, h.quatern_y, h.quatern_z].map(|v| v as f64));
        if origin.iter().all(|c| c.is_finite()) {
            return (Some(origin), unit_axes([col(0), col(1), col(2)]));
        }
    }
    (None, None)
}

fn nifti_err(path: &Path, e: nifti::NiftiError) -> Error {
    match e {
        nifti::NiftiError::Io(io) if io.kind() == ErrorKind::UnexpectedEof => format_err(
            path,
            format!("truncated: a NIfTI-1 header needs {NIFTI_HEADER} bytes"),
        ),
        nifti::NiftiError::Io(io) => data_err(path, io),
        nifti::NiftiError::InvalidFormat => format_err(
            path,
            "not a NIfTI-1 file (bad magic; NIfTI-2 is not supported)",
        ),
        other => format_err(path, format!("bad NIfTI header: {other}")),
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    #[test]
    fn placement_prefers_the_sform_then_the_qform_in_lps() {
        // The qform: 180 degrees about z (RAS), qfac -1 flips k.
        let mut h = nifti::NiftiHeader {
            qform_code: 1,
            sform_code: 0,
            quatern_d: 1.0,
            quatern_x: 10.0,
            quatern_y: 20.0,
            quatern_z: 30.0,
            ..Default::default()
        };
        h.pixdim[0] = -1.0;
        let (o, a) = placement(&h);
        assert_eq!(o, Some([-10.0, -20.0, 30.0]));
        assert_eq!(
            a,
            Some([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
        );
        // An sform wins: i along A (RAS +y) at 2 mm, j along R, k along S.
        h.sform_code = 2;
        h.srow_x = [0.0, 1.5, 0.0, 4.0];
        h.srow_y = [2.0, 0.0, 0.0, 5.0];
        h.srow_z = [0.0, 0.0, 3.0, 6.0];
        let (o, a) = placement(&h);
        assert_eq!(o, Some([-4.0, -5.0, 6.0]));
        assert_eq!(
            a,
            Some([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        );
        // Neither: no placement.
        h.sform_code = 0;
        h.qform_code = 0;
        assert_eq!(placement(&h), (None, None));
    }
    use crate::load::tests::{assert_err, gzip, pattern, write};
    use crate::volume::{VoxelType, DEFAULT_MEMORY_LIMIT};

    /// Fields of a hand-written NIfTI-1 file.
    #[derive(Clone)]
    pub(crate) struct Nii {
        dim: [i16; 8],
        datatype: i16,
        bitpix: i16,
        pixdim: [f32; 8],
        vox_offset: f32,
        magic: [u8; 4],
        sizeof_hdr: i32,
        big: bool,
    }

    impl Nii {
        pub(crate) fn new(dims: [i16; 3], datatype: i16, bitpix: i16) -> Nii {
            Nii {
                dim: [3, dims[0], dims[1], dims[2], 1, 1, 1, 1],
                datatype,
                bitpix,
                pixdim: [1.0, 0.5, 0.75, 2.0, 1.0, 1.0, 1.0, 1.0],
                vox_offset: 352.0,
                magic: *b"n+1\0",
                sizeof_hdr: 348,
                big: false,
            }
        }

        /// The 348-byte header, the 4-byte extension flag, any padding up
        /// to `vox_offset`, then `data` (already in the file's byte order).
        pub(crate) fn bytes(&self, data: &[u8]) -> Vec<u8> {
            let mut h = vec![0u8; 348];
            let big = self.big;
            let i16b = |v: i16| {
                if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            };
            let f32b = |v: f32| {
                if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            };
            let i32b = |v: i32| {
                if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            };
            h[0..4].copy_from_slice(&i32b(self.sizeof_hdr));
            for (k, &d) in self.dim.iter().enumerate() {
                h[40 + 2 * k..42 + 2 * k].copy_from_slice(&i16b(d));
            }
            h[70..72].copy_from_slice(&i16b(self.datatype));
            h[72..74].copy_from_slice(&i16b(self.bitpix));
            for (k, &p) in self.pixdim.iter().enumerate() {
                h[76 + 4 * k..80 + 4 * k].copy_from_slice(&f32b(p));
            }
            h[108..112].copy_from_slice(&f32b(self.vox_offset));
            h[112..116].copy_from_slice(&f32b(1.0)); // scl_slope
            h[344..348].copy_from_slice(&self.magic);
            h.extend([0; 4]);
            while (h.len() as f32) < self.vox_offset {
                h.push(0);
            }
            h.extend_from_slice(data);
            h
        }
    }

    #[test]
    fn nifti_u8_round_trips_and_agrees_with_the_crate_reader() {
        let dir = tempfile::tempdir().unwrap();
        let data: Vec<u8> = pattern(7 * 6 * 5, 256).iter().map(|&v| v as u8).collect();
        let bytes = Nii::new([7, 6, 5], 2, 8).bytes(&data);
        for (name, file) in [("a.nii", bytes.clone()), ("a.nii.gz", gzip(&bytes))] {
            let path = write(&dir, name, &file);
            let v = load_nifti(&path, DEFAULT_MEMORY_LIMIT).unwrap();
            assert_eq!(v.dims(), [7, 6, 5]);
            assert_eq!(v.kind(), VoxelType::U8);
            assert_eq!(v.spacing(), [0.5, 0.75, 2.0]);
            assert!(v.data().iter().zip(&data).all(|(&a, &b)| a == b as u16));
            // Our hand-written file is a real NIfTI: the crate reads the same.
            use nifti::NiftiObject;
            let obj = nifti::ReaderOptions::new().read_file(&path).unwrap();
            assert_eq!(obj.header().dim[..4], [3, 7, 6, 5]);
            assert_eq!(obj.into_volume().into_raw_data(), data);
        }
    }

    #[test]
    fn nifti_16_bit_types_in_both_byte_orders() {
        let dir = tempfile::tempdir().unwrap();
        let n = 4 * 3 * 2;
        let uvals = pattern(n, 65536);
        let ivals: Vec<i16> = (0..n).map(|i| i as i16 * 1000 - 9000).collect();
        for big in [false, true] {
            let enc16 = |v: u16| {
                if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            };
            let mut nii = Nii::new([4, 3, 2], 512, 16);
            nii.big = big;
            let udata: Vec<u8> = uvals.iter().flat_map(|&v| enc16(v)).collect();
            let path = write(&dir, "u.nii.gz", &gzip(&nii.bytes(&udata)));
            let v = load_nifti(&path, DEFAULT_MEMORY_LIMIT).unwrap();
            assert_eq!((v.kind(), &*v.data()), (VoxelType::U16, &uvals[..]));

            nii.datatype = 4;
            let idata: Vec<u8> = ivals.iter().flat_map(|&v| enc16(v as u16)).collect();
            let path = write(&dir, "i.nii", &nii.bytes(&idata));
            let v = load_nifti(&path, DEFAULT_MEMORY_LIMIT).unwrap();
            let want: Vec<u16> = ivals.iter().map(|&x| (x as i32 + 9000) as u16).collect();
            assert_eq!((v.kind(), &*v.data()), (VoxelType::U16, &want[..]));

            // Non-negative int16 keeps its values.
            let pos: Vec<u8> = (0..n as u16).flat_map(|x| enc16(x * 3)).collect();
            let path = write(&dir, "p.nii", &nii.bytes(&pos));
            let v = load_nifti(&path, DEFAULT_MEMORY_LIMIT).unwrap();
            assert!(v.data().iter().enumerate().all(|(i, &x)| x == 3 * i as u16));
        }
    }

    #[test]
    fn nifti_float32_is_rescaled_to_the_full_u16_range() {
        let dir = tempfile::tempdir().unwrap();
        let vals = [-2.0f32, -1.0, 0.0, 2.0, f32::NAN, 1.0, f32::INFINITY, 0.5];
        let data: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        let mut nii = Nii::new([2, 2, 2], 16, 32);
        nii.pixdim = [1.0, 0.5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        let path = write(&dir, "f.nii", &nii.bytes(&data));
        let v = load_nifti(&path, DEFAULT_MEMORY_LIMIT).unwrap();
        assert_eq!(v.kind(), VoxelType::U16);
        let s = 65535.0 / 4.0;
        let want: Vec<u16> = [0.0, 1.0, 2.0, 4.0, f64::NAN, 3.0, f64::NAN, 2.5]
            .iter()
            .map(|&x: &f64| {
                if x.is_nan() {
                    0
                } else {
                    (x * s).round() as u16
                }
            })
            .collect();
        assert_eq!(v.data(), &want[..]);
        assert_eq!(v.spacing(), [0.5, 1.0, 1.0]);

        let flat: Vec<u8> = [3.0f32; 8].iter().flat_map(|v| v.to_le_bytes()).collect();
        let path = write(&dir, "flat.nii", &nii.bytes(&flat));
        assert!(load_nifti(&path, DEFAULT_MEMORY_LIMIT)
            .unwrap()
            .data()
            .iter()
            .all(|&x| x == 0));
    }

    #[test]
    fn nifti_shapes_other_than_3d_are_handled() {
        let dir = tempfile::tempdir().unwrap();
        let lim = DEFAULT_MEMORY_LIMIT;
        let mut nii = Nii::new([2, 2, 2], 2, 8);
        nii.dim[0] = 4;
        let path = write(&dir, "t1.nii", &nii.bytes(&[5; 8]));
        assert_eq!(load_nifti(&path, lim).unwrap().dims(), [2, 2, 2]);
        nii.dim[4] = 2;
        let path = write(&dir, "t2.nii", &nii.bytes(&[5; 16]));
        assert_err(load_nifti(&path, lim), "dim[4] = 2");
        let mut flat = Nii::new([2, 2, 1], 2, 8);
        flat.dim[0] = 2;
        let path = write(&dir, "2d.nii", &flat.bytes(&[5; 4]));
        assert_err(load_nifti(&path, lim), "2 dimensions");
    }

    #[test]
    fn corrupt_nifti_headers_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let lim = DEFAULT_MEMORY_LIMIT;
        let good = Nii::new([2, 2, 2], 2, 8);
        let check = |nii: &Nii, data: &[u8], needle: &str| {
            let path = write(&dir, "bad.nii", &nii.bytes(data));
            assert_err(load_nifti(&path, lim), needle);
        };
        check(
            &Nii {
                datatype: 64,
                bitpix: 64,
                ..good.clone()
            },
            &[0; 64],
            "unsupported NIfTI datatype",
        );
        check(
            &Nii {
                datatype: 3,
                ..good.clone()
            },
            &[0; 8],
            "unknown NIfTI datatype code 3",
        );
        check(
            &Nii {
                bitpix: 16,
                ..good.clone()
            },
            &[0; 8],
            "bitpix 16 disagrees",
        );
        check(
            &Nii {
                vox_offset: 100.0,
                ..good.clone()
            },
            &[0; 8],
            "vox_offset 100",
        );
        check(
            &Nii {
                vox_offset: f32::NAN,
                ..good.clone()
            },
            &[0; 8],
            "vox_offset NaN",
        );
        check(
            &Nii {
                magic: *b"ni1\0",
                ..good.clone()
            },
            &[0; 8],
            ".hdr/.img",
        );
        check(
            &Nii {
                magic: *b"xyz\0",
                ..good.clone()
            },
            &[0; 8],
            "bad magic",
        );
        check(
            &Nii {
                sizeof_hdr: 540,
                ..good.clone()
            },
            &[0; 8],
            "sizeof_hdr is 540",
        );
        check(
            &good,
            &[0; 5],
            "truncated: expected 8 bytes of voxel data at offset 352, found 5",
        );
        check(
            &Nii {
                vox_offset: 400.0,
                ..good.clone()
            },
            &[],
            "truncated",
        );
        let path = write(&dir, "short.nii", &good.bytes(&[0; 8])[..200]);
        assert_err(
            load_nifti(&path, lim),
            "truncated: a NIfTI-1 header needs 348 bytes",
        );
        let gz = gzip(&good.bytes(&[0; 8]));
        let path = write(&dir, "cut.nii.gz", &gz[..gz.len() - 12]);
        assert!(load_nifti(&path, lim).is_err());
    }

    #[test]
    fn absurd_nifti_dims_are_refused_without_allocating() {
        let dir = tempfile::tempdir().unwrap();
        let lim = DEFAULT_MEMORY_LIMIT;
        // Each of these would need terabytes if trusted; the file is tiny.
        let cases: [([i16; 3], &str); 4] = [
            ([30000, 30000, 30000], "absurd"),
            ([-5, 4, 4], "absurd"),
            ([0, 4, 4], "zero"),
            ([8000, 8000, 8000], "over the memory limit"),
        ];
        for (dims, needle) in cases {
            let path = write(&dir, "huge.nii", &Nii::new(dims, 16, 32).bytes(&[0; 64]));
            assert_err(load_nifti(&path, lim), needle);
        }
        let path = write(
            &dir,
            "small.nii",
            &Nii::new([8, 8, 8], 2, 8).bytes(&[1; 512]),
        );
        assert_err(load_nifti(&path, 1000), "over the memory limit");
        assert!(load_nifti(&path, 1024).is_ok());
    }
}
