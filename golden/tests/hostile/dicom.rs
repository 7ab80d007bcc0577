//! DICOM series with edited lengths, segment counts and attributes.

use super::*;

/// Byte offset of the first `tag` (group, element; little endian) after the
/// 132-byte preamble.
fn find_tag(b: &[u8], group: u16, elem: u16) -> usize {
    let mut t = group.to_le_bytes().to_vec();
    t.extend_from_slice(&elem.to_le_bytes());
    132 + b[132..]
        .windows(4)
        .position(|w| w == t)
        .expect("tag present")
}

/// A copy of the fixture series `name` with the file `victim` replaced by
/// `edit` of its bytes.
fn edited_series(name: &str, edit: impl Fn(&mut Vec<u8>)) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let mut files: Vec<_> = std::fs::read_dir(data(name))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    for (k, f) in files.iter().enumerate() {
        let mut b = std::fs::read(f).unwrap();
        if k == 0 {
            edit(&mut b);
        }
        std::fs::write(dir.path().join(f.file_name().unwrap()), b).unwrap();
    }
    dir
}

#[test]
fn dicom_lengths_segment_counts_and_attributes_are_checked() {
    let _g = serial();
    // Explicit VR: PixelData (OW) length after 2 reserved bytes.
    for len in [0xFFFF_FFF0u32, 0x7FFF_FFFF] {
        let dir = edited_series("dicom_u16", |b| {
            let at = find_tag(b, 0x7FE0, 0x0010);
            b[at + 8..at + 12].copy_from_slice(&len.to_le_bytes());
        });
        refused(
            dir.path(),
            &format!("element (7FE0,0010) claims {len} bytes"),
        );
    }
    // Implicit VR: an ordinary element's length off by a few bytes.
    let dir = edited_series("dicom_i16", |b| {
        let at = find_tag(b, 0x0028, 0x0004);
        b[at + 4..at + 8].copy_from_slice(&0x2000_0000u32.to_le_bytes());
    });
    refused(dir.path(), "element (0028,0004) claims");
    let attr = |tag: (u16, u16), value: &[u8], needle: &str| {
        let dir = edited_series("dicom_i16", |b| {
            let at = find_tag(b, tag.0, tag.1) + 8;
            b[at..at + value.len()].copy_from_slice(value);
        });
        refused(dir.path(), needle);
    };
    attr((0x0028, 0x1053), b"nan ", "RescaleSlope NaN");
    attr(
        (0x0028, 0x0004),
        b"RGB         ",
        "PhotometricInterpretation RGB",
    );
    attr((0x0028, 0x0101), &[17, 0], "BitsStored 17");
    attr((0x0028, 0x0102), &[99, 0], "HighBit 99");
    // RLE: a segment count of 0xFFFFFFFF (the decoder would allocate 16
    // GiB of offsets) and a first fragment of garbage.
    let rle = fixture("dicom_mf_u8.dcm");
    let header = [1u8, 0, 0, 0, 64, 0, 0, 0];
    let at = rle
        .windows(8)
        .position(|w| w == header)
        .expect("an RLE header");
    let dir = tempfile::tempdir().unwrap();
    let mut b = rle.clone();
    b[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    refused(&write(dir.path(), "count.dcm", &b), "4294967295 segments");
    let mut b = rle.clone();
    b[at..at + 64]
        .iter_mut()
        .enumerate()
        .for_each(|(i, x)| *x = (i * 97 + 13) as u8);
    let m = load_small(&write(dir.path(), "garbage.dcm", &b)).expect("refused");
    assert!(m.contains("RLE fragment 1"), "{m}");
}

/// A control character inside a quoted attribute (a newline in
/// PhotometricInterpretation) is escaped: the error stays one line.
#[test]
fn a_newline_in_an_attribute_stays_one_line() {
    let _g = serial();
    let dir = edited_series("dicom_u8", |b| {
        let at = b
            .windows(11)
            .position(|w| w == b"MONOCHROME2")
            .expect("PhotometricInterpretation value");
        b[at + 1] = b'\n';
    });
    refused(dir.path(), "PhotometricInterpretation M\\nNOCHROME2");
}

/// The meta group ends where its group length (0002,0000) says, as the
/// parser reads it: a length that stops after the transfer syntax leaves
/// (0002,0012) to the implicit-VR data set, where its `UI` bytes read as
/// a 4-byte length of about 4.8 MB. The walk checks that length where the
/// parser will read it.
#[test]
fn the_meta_group_ends_where_its_group_length_says() {
    let _g = serial();
    let dir = edited_series("dicom_i16", |b| {
        let gl = find_tag(b, 0x0002, 0x0000);
        let ts = find_tag(b, 0x0002, 0x0010);
        let ts_len = u16::from_le_bytes([b[ts + 6], b[ts + 7]]) as usize;
        let meta_end = ts + 8 + ts_len;
        let value = (meta_end - (gl + 12)) as u32;
        b[gl + 8..gl + 12].copy_from_slice(&value.to_le_bytes());
    });
    refused(dir.path(), "element (0002,0012) claims");
}
