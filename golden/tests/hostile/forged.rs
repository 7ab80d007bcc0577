//! Forged headers, lengths and TIFF layouts, folder members that are no
//! files, detached data outside the header's folder, spacings outside
//! the rule and corrupted compressed streams, one loader at a time.

use super::*;

#[test]
fn headers_promising_more_than_the_file_are_refused_before_allocating() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 2048x2048x1024 int16 (8 GiB) in the 352 bytes of a header.
    let nii = nifti_header([2048, 2048, 1024], [1.0; 3]);
    refused(&write(d, "big.nii", &nii), "truncated");
    let mut padded = nii.clone();
    padded.extend_from_slice(&[0; 4096]);
    refused(&write(d, "big.nii.gz", &gzip(&padded)), "truncated");
    // The same size in a MetaImage with 1 KiB of zlib data.
    let mut mha = b"ObjectType = Image\nNDims = 3\nDimSize = 2048 2048 1024\n\
ElementType = MET_SHORT\nCompressedData = True\nElementDataFile = LOCAL\n"
        .to_vec();
    mha.extend_from_slice(&zlib(&[7; 1024]));
    refused(&write(d, "big.mha", &mha), "truncated");
    let mut nrrd = b"NRRD0004\ntype: short\ndimension: 3\nsizes: 2048 2048 1024\n\
endian: little\nencoding: gzip\n\n"
        .to_vec();
    nrrd.extend_from_slice(&gzip(&[7; 1024]));
    refused(&write(d, "big.nrrd", &nrrd), "truncated");
}

/// A little-endian TIFF of `pages` pages of `w`x`h` 16-bit greyscale, each
/// one strip of `strip` (stored as-is) under `compression`, the strip at
/// `offset` if given (else where it was written) with byte count `count`
/// if given.
fn tiff(
    w: u32,
    h: u32,
    pages: usize,
    compression: u16,
    strip: &[u8],
    offset: Option<u32>,
    count: Option<u32>,
) -> Vec<u8> {
    let mut f = b"II*\0".to_vec();
    f.extend_from_slice(&0u32.to_le_bytes());
    let mut next_at = 4usize;
    for _ in 0..pages {
        let data_at = f.len() as u32;
        f.extend_from_slice(strip);
        if f.len() % 2 == 1 {
            f.push(0);
        }
        let ifd_at = f.len() as u32;
        f[next_at..next_at + 4].copy_from_slice(&ifd_at.to_le_bytes());
        let entries: [(u16, u16, u32); 9] = [
            (256, 4, w),
            (257, 4, h),
            (258, 3, 16),
            (259, 3, compression as u32),
            (262, 3, 1),
            (273, 4, offset.unwrap_or(data_at)),
            (277, 3, 1),
            (278, 4, h),
            (279, 4, count.unwrap_or(strip.len() as u32)),
        ];
        f.extend_from_slice(&(entries.len() as u16).to_le_bytes());
        for (tag, ty, v) in entries {
            f.extend_from_slice(&tag.to_le_bytes());
            f.extend_from_slice(&ty.to_le_bytes());
            f.extend_from_slice(&1u32.to_le_bytes());
            if ty == 3 {
                f.extend_from_slice(&(v as u16).to_le_bytes());
                f.extend_from_slice(&[0, 0]);
            } else {
                f.extend_from_slice(&v.to_le_bytes());
            }
        }
        next_at = f.len();
        f.extend_from_slice(&0u32.to_le_bytes());
    }
    f
}

#[test]
fn tiff_pages_and_strips_that_cannot_hold_the_page_are_refused() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Two deflate pages of 8192x8192 (256 MiB) in a few hundred bytes.
    let bomb = tiff(8192, 8192, 2, 8, &zlib(&[0; 4096]), None, None);
    refused(
        &write(d, "bomb.tif", &bomb),
        "too few for a 8192x8192 16-bit page",
    );
    // An uncompressed 4x4 page (32 bytes) whose strip is misplaced or short.
    let px = [1u8; 32];
    let ok = tiff(4, 4, 1, 1, &px, None, None);
    assert_eq!(load_small(&write(d, "ok.tif", &ok)), None);
    for (name, offset, count, needle) in [
        ("off0.tif", Some(0), None, "does not lie in the file"),
        ("count0.tif", None, Some(0), "does not lie in the file"),
        ("count1.tif", None, Some(1), "its strips hold 1 bytes"),
        ("past.tif", Some(1 << 20), None, "does not lie in the file"),
    ] {
        refused(
            &write(d, name, &tiff(4, 4, 1, 1, &px, offset, count)),
            needle,
        );
    }
    // A directory entry whose value count is forged to two million: the
    // decoder would size a table by it.
    let mut forged = ok.clone();
    let entry = forged
        .windows(4)
        .position(|w| w == [23, 1, 4, 0])
        .expect("the StripByteCounts entry (tag 279, LONG)");
    forged[entry + 4..entry + 8].copy_from_slice(&0x0020_0001u32.to_le_bytes());
    refused(
        &write(d, "forged.tif", &forged),
        "tag 279 claims 2097153 values",
    );
    // A chain of pages that loops back to the first.
    let mut looped = tiff(4, 4, 2, 1, &px, None, None);
    let first = u32::from_le_bytes([looped[4], looped[5], looped[6], looped[7]]);
    let n = looped.len();
    looped[n - 4..].copy_from_slice(&first.to_le_bytes());
    refused(&write(d, "loop.tif", &looped), "the chain of pages loops");
}

/// Makes a folder member that is no file at the given path.
type MakeMember = fn(&Path);

#[test]
fn tiff_folder_members_that_are_no_files_are_refused_by_name() {
    let _g = serial();
    let page = tiff(4, 4, 1, 1, &[1u8; 32], None, None);
    let cases: [(&str, MakeMember); 3] = [
        ("b.tif", |p| std::fs::create_dir(p).unwrap()),
        ("b.tif", |p| {
            std::os::unix::fs::symlink(p.with_file_name("gone.tif"), p).unwrap()
        }),
        ("b.tif", |p| {
            std::os::unix::fs::symlink(p.with_file_name("c.tif"), p).unwrap();
            std::os::unix::fs::symlink(p, p.with_file_name("c.tif")).unwrap();
        }),
    ];
    for (k, (name, make)) in cases.iter().enumerate() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "a.tif", &page);
        write(dir.path(), "d.tif", &page);
        make(&dir.path().join(name));
        let m = load_small(dir.path()).unwrap_or_else(|| panic!("case {k} loaded"));
        assert!(m.contains("b.tif"), "case {k}: {m}");
        let want = if k == 0 {
            "is a folder"
        } else {
            "leads nowhere"
        };
        assert!(m.contains(want), "case {k}: {m}");
    }
}

#[test]
fn detached_data_files_stay_in_the_header_folder() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    std::fs::copy(data("vol_u8_det.raw"), dir.path().join("outside.raw")).unwrap();
    std::fs::copy(data("vol_u8_det.raw"), sub.join("inside.raw")).unwrap();
    let nhdr = |file: &str| {
        format!(
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 12 10 7\nencoding: raw\ndata file: {file}\n"
        )
    };
    let mhd = |file: &str| {
        format!("NDims = 3\nDimSize = 12 10 7\nElementType = MET_UCHAR\nElementDataFile = {file}\n")
    };
    let outside = dir.path().join("outside.raw");
    let outside = outside.to_str().unwrap();
    for (name, text, needle) in [
        ("a.nhdr", nhdr("../outside.raw"), "steps out with '..'"),
        ("b.nhdr", nhdr(outside), "is an absolute path"),
        ("c.mhd", mhd("../outside.raw"), "steps out with '..'"),
        ("d.mhd", mhd(outside), "is an absolute path"),
        ("e.nhdr", nhdr("/etc/passwd"), "is an absolute path"),
    ] {
        let p = write(&sub, name, text.as_bytes());
        refused(&p, needle);
        if !name.starts_with('e') {
            allow_outside_data(true);
            let loaded = load_small(&p);
            allow_outside_data(false);
            assert_eq!(loaded, None, "{name} with outside data allowed");
        }
    }
    std::os::unix::fs::symlink(dir.path().join("outside.raw"), sub.join("link.raw")).unwrap();
    refused(
        &write(&sub, "f.nhdr", nhdr("link.raw").as_bytes()),
        "leads out",
    );
    assert_eq!(
        load_small(&write(&sub, "g.nhdr", nhdr("inside.raw").as_bytes())),
        None
    );
}

#[test]
fn spacings_outside_the_one_rule_are_refused_in_every_format() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (k, s) in ["nan", "0", "-1", "inf", "1e-150", "1e30"]
        .iter()
        .enumerate()
    {
        let v: f64 = s.parse().unwrap();
        let nrrd = format!(
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nspacings: 1 {s} 1\nencoding: raw\n\n"
        );
        let mut nrrd = nrrd.into_bytes();
        nrrd.extend_from_slice(&[1; 8]);
        refused(&write(d, &format!("{k}.nrrd"), &nrrd), "spacings");
        let mut mha = format!(
            "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementSpacing = {s} 1 1\n\
ElementDataFile = LOCAL\n"
        )
        .into_bytes();
        mha.extend_from_slice(&[1; 8]);
        refused(&write(d, &format!("{k}.mha"), &mha), "ElementSpacing");
        let mut nii = nifti_header([2, 2, 2], [1.0, 1.0, v as f32]);
        nii.extend_from_slice(&[1; 16]);
        refused(&write(d, &format!("{k}.nii"), &nii), "pixdim");
    }
    // The ends of the range load.
    let mut nii = nifti_header([2, 2, 2], [2e-6, 1e6, 1.0]);
    nii.extend_from_slice(&[1; 16]);
    assert_eq!(load_small(&write(d, "ends.nii", &nii)), None);
}

#[test]
fn compressed_streams_are_read_to_their_checksums() {
    let _g = serial();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut nii = nifti_header([2, 2, 2], [1.0; 3]);
    nii.extend_from_slice(&[1; 16]);
    let gz = gzip(&nii);
    assert_eq!(load_small(&write(d, "ok.nii.gz", &gz)), None);
    // The gzip trailer is CRC-32 then length: zero the CRC.
    let mut bad = gz.clone();
    let n = bad.len();
    bad[n - 8..n - 4].fill(0);
    refused(&write(d, "crc.nii.gz", &bad), "unreadable data");
    for (name, ext) in [
        ("vol_u8_gz.nrrd", "nrrd"),
        ("vol_u8_detgz.raw.gz", "raw.gz"),
    ] {
        let mut b = fixture(name);
        let n = b.len();
        b[n - 8..n - 4].iter_mut().for_each(|x| *x ^= 0xff);
        write(d, &format!("vol_u8_detgz.{ext}"), &b);
    }
    refused(&d.join("vol_u8_detgz.nrrd"), "unreadable data");
    std::fs::copy(data("vol_u8_detgz.nhdr"), d.join("vol_u8_detgz.nhdr")).unwrap();
    refused(&d.join("vol_u8_detgz.nhdr"), "unreadable data");
    // zlib's trailer is the Adler-32 of the data.
    let mut z = fixture("vol_u8_z.zraw");
    let n = z.len();
    z[n - 1] ^= 0xff;
    write(d, "vol_u8_z.zraw", &z);
    std::fs::copy(data("vol_u8_z.mhd"), d.join("vol_u8_z.mhd")).unwrap();
    refused(&d.join("vol_u8_z.mhd"), "unreadable data");
}
