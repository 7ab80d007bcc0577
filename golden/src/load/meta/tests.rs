//! Unit tests of the MetaImage loader: header parsing, data layouts, bad
//! and random input.

use super::*;
use crate::load::tests::{assert_err, assert_headers_refused, gzip, u16_data, write};
use crate::volume::{VoxelType, DEFAULT_MEMORY_LIMIT};
use proptest::prelude::*;
use std::io::Write;

const LIM: u64 = DEFAULT_MEMORY_LIMIT;

/// A 4x3x2 header of `ty` with `extra` keys, data in `file`.
fn header(ty: &str, extra: &str, file: &str) -> String {
    format!(
        "ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\nElementType = {ty}\n{extra}\
         ElementDataFile = {file}\n"
    )
}

fn parse(text: &str) -> std::result::Result<Header, String> {
    parse_header(&text.lines().map(str::to_owned).collect::<Vec<_>>())
}

fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(bytes).unwrap();
    enc.finish().unwrap()
}

#[test]
fn meta_header_keys_and_placement() {
    let text = "objecttype = image\nNDims = 4\nDimSize = 4 3 2 1\nElementType = met_short\n\
                ElementByteOrderMSB = True\nElementSize = 2 3 1 1\n\
                TransformMatrix = 0 2 0 0  1 0 0 0  0 0 1 0  0 0 0 1\n\
                Origin = 1 2 3 4\nCenterOfRotation = 0 0 0 0\nCompressedData = 1\n\
                CompressedDataSize = 99\nElementDataFile = x.zraw";
    let h = parse(text).unwrap();
    assert_eq!((h.dims, h.scalar, h.big), ([4, 3, 2], Scalar::I16, true));
    assert_eq!(h.spacing, [2.0, 3.0, 1.0]);
    assert_eq!(
        h.axes,
        Some([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    );
    assert_eq!(h.origin, Some([1.0, 2.0, 3.0]));
    assert_eq!((h.compressed, h.compressed_size), (true, Some(99)));
    assert_eq!(h.data_file, DataFile::File("x.zraw".into()));
    // ElementSpacing wins over ElementSize; defaults little-endian, LOCAL.
    let h = parse(&header(
        "MET_DOUBLE",
        "ElementSpacing = 0.5 1 1\nElementSize = 9 9 9\n",
        "local",
    ))
    .unwrap();
    assert_eq!(
        (h.scalar, h.big, h.spacing),
        (Scalar::F64, false, [0.5, 1.0, 1.0])
    );
    assert_eq!(
        (h.data_file, h.header_size, h.axes),
        (DataFile::Local, 0, None)
    );
}

#[test]
fn bad_meta_headers_are_refused() {
    let u8h = |extra: &str| header("MET_UCHAR", extra, "LOCAL");
    let cases: Vec<(String, &str)> = vec![
        (
            "P5\n12 10\nElementDataFile = x".into(),
            "line 1 'P5' is not 'Key = Value'",
        ),
        (u8h("NDims = 3\n"), "key 'NDims' is given twice"),
        (
            u8h("").replace("ObjectType = Image", "ObjectType = Tube"),
            "'Tube' is not Image",
        ),
        (u8h("").replace("NDims = 3\n", ""), "'NDims' is missing"),
        (
            u8h("").replace("NDims = 3", "NDims = 2"),
            "NDims 2: only 3D",
        ),
        (u8h("").replace("NDims = 3", "NDims = x"), "NDims 'x'"),
        (u8h("").replace("4 3 2", "4 3"), "has 2 values, 3 expected"),
        (
            u8h("").replace("NDims = 3\nDimSize = 4 3 2", "NDims = 4\nDimSize = 4 3 2 2"),
            "a 4D image, axis 3 has 2",
        ),
        (
            header("MET_LONG", "", "LOCAL"),
            "unsupported ElementType 'MET_LONG'",
        ),
        (
            header("MET_UCHAR_ARRAY", "", "LOCAL"),
            "unsupported ElementType",
        ),
        (u8h("ElementNumberOfChannels = 3\n"), "1-channel"),
        (u8h("BinaryData = False\n"), "text voxels"),
        (u8h("BinaryData = maybe\n"), "BinaryData 'maybe' is neither"),
        (
            u8h("BinaryDataByteOrderMSB = True\nElementByteOrderMSB = False\n"),
            "disagree",
        ),
        (u8h("ElementSpacing = 1 1\n"), "has 2 values"),
        (u8h("CompressedDataSize = -4\n"), "CompressedDataSize '-4'"),
        (u8h("HeaderSize = -2\n"), "HeaderSize '-2'"),
        (
            u8h("HeaderSize = -1\nCompressedData = True\n"),
            "needs uncompressed",
        ),
        (u8h("TransformMatrix = 1 0 0\n"), "has 3 values, 9 expected"),
        (u8h("Offset = 1 a 2\n"), "not a list of numbers"),
        (
            header("MET_UCHAR", "", "LIST"),
            "only LOCAL or a single data file",
        ),
        (header("MET_UCHAR", "", "s%03d.raw 1 10 1"), "only LOCAL"),
    ];
    assert_headers_refused(&cases, parse);
}

#[test]
fn meta_local_and_external_data() {
    let dir = tempfile::tempdir().unwrap();
    let (vals, be) = u16_data(true);
    let (_, le) = u16_data(false);
    let check = |name: &str, bytes: &[u8]| {
        let v = load_meta(&write(&dir, name, bytes), LIM).unwrap();
        assert_eq!(
            (v.kind(), &*v.data()),
            (VoxelType::U16, &vals[..]),
            "{name}"
        );
    };
    let h = header("MET_USHORT", "BinaryDataByteOrderMSB = True\n", "LOCAL");
    check("a.mha", &[h.as_bytes(), &be, b"trailing"].concat());
    // HeaderSize is ignored for LOCAL data, as MetaIO does.
    let h = header("MET_USHORT", "HeaderSize = 7\n", "LOCAL");
    check("b.mha", &[h.as_bytes(), &le].concat());
    // zlib inline, bounded by CompressedDataSize; gzip by its magic.
    let z = zlib(&le);
    let h = header(
        "MET_USHORT",
        &format!("CompressedData = True\nCompressedDataSize = {}\n", z.len()),
        "LOCAL",
    );
    check("c.mha", &[h.as_bytes(), &z, b"junk after"].concat());
    write(&dir, "d.zraw", &gzip(&le));
    check(
        "d.mhd",
        header("MET_USHORT", "CompressedData = True\n", "d.zraw").as_bytes(),
    );
    // External raw: HeaderSize skips bytes; -1 takes the end of the file.
    write(&dir, "e.raw", &[&[5; 9], &le[..]].concat());
    check(
        "e.mhd",
        header("MET_USHORT", "HeaderSize = 9\n", "e.raw").as_bytes(),
    );
    check(
        "f.mhd",
        header("MET_USHORT", "HeaderSize = -1\n", "e.raw").as_bytes(),
    );
}

#[test]
fn truncated_or_absurd_meta_data_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (_, le) = u16_data(false);
    let h = header("MET_USHORT", "", "LOCAL");
    assert_err(
        load_meta(
            &write(&dir, "a.mha", &[h.as_bytes(), &le[..47]].concat()),
            LIM,
        ),
        &format!(
            "truncated: expected 48 bytes of voxel data at offset {}, found 47",
            h.len()
        ),
    );
    let h = header("MET_USHORT", "CompressedData = True\n", "LOCAL");
    let z = zlib(&le);
    let bytes = [h.as_bytes(), &z[..z.len() - 6]].concat();
    assert!(load_meta(&write(&dir, "b.mha", &bytes), LIM).is_err());
    write(&dir, "d.raw", &le[..10]);
    let refused = [
        (
            "c.mhd",
            header("MET_USHORT", "", "missing.raw"),
            "missing.raw",
        ),
        (
            "d.mhd",
            header("MET_USHORT", "HeaderSize = -1\n", "d.raw"),
            "truncated",
        ),
        (
            "e.mha",
            header("MET_UCHAR", "", "LOCAL").replace("DimSize = 4 3 2", "Dim = 4"),
            "'DimSize' is missing",
        ),
        (
            "f.mha",
            "NDims = 3\nDimSize = 4 3 2\n".to_string(),
            "without an ElementDataFile",
        ),
        // Huge sizes in a tiny file: refused before allocating.
        (
            "g.mha",
            header("MET_DOUBLE", "", "LOCAL").replace("4 3 2", "8000 8000 8000"),
            "over the memory limit",
        ),
    ];
    for (name, h, needle) in refused {
        assert_err(load_meta(&write(&dir, name, h.as_bytes()), LIM), needle);
    }
    let h = header("MET_UCHAR", "", "LOCAL").replace("4 3 2", "4 3 0");
    assert_err(load_meta(&write(&dir, "h.mha", h.as_bytes()), LIM), "zero");
    assert_err(
        load_meta(&write(&dir, "i.mha", &[0xff; 5000]), LIM),
        "not text",
    );
}

/// Header lines of random keys, values and junk.
fn random_line() -> impl Strategy<Value = String> {
    let key = prop::sample::select(vec![
        "ObjectType",
        "NDims",
        "DimSize",
        "ElementType",
        "ElementSpacing",
        "HeaderSize",
        "CompressedData",
        "CompressedDataSize",
        "BinaryDataByteOrderMSB",
        "TransformMatrix",
        "Offset",
        "ElementNumberOfChannels",
        "BinaryData",
    ]);
    let value = prop::sample::select(vec![
        "Image",
        "3",
        "4",
        "2",
        "-1",
        "0",
        "4 3 2",
        "1 1 1",
        "MET_UCHAR",
        "MET_FLOAT",
        "True",
        "False",
        "1 0 0 0 1 0 0 0 1",
        "nan nan nan",
        "",
        "x",
    ]);
    prop_oneof![
        (key, value).prop_map(|(k, v)| format!("{k} = {v}")),
        "[ -~]{0,30}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Random headers without DimSize are errors, never panics.
    #[test]
    fn random_meta_headers_are_refused(body in prop::collection::vec(random_line(), 0..12)) {
        let mut text: Vec<String> = body
            .into_iter()
            .filter(|l| !l.to_ascii_lowercase().starts_with("dimsize"))
            .collect();
        text.push("ElementDataFile = LOCAL".into());
        prop_assert!(parse_header(&text).is_err());
        text.insert(0, "DimSize = 4 3 2".into());
        let _ = parse_header(&text);
    }

    /// Mutated MetaImage files (header and data) load or fail, never panic.
    #[test]
    fn mutated_meta_files_never_panic(
        z in any::<bool>(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let (_, le) = u16_data(false);
        let extra = if z { "CompressedData = True\n" } else { "" };
        let h = header("MET_USHORT", extra, "LOCAL");
        let mut bytes = [h.as_bytes(), &if z { zlib(&le) } else { le }].concat();
        for (at, b) in edits {
            let i = at.index(bytes.len());
            bytes[i] = b;
        }
        let _ = load_meta(&write(&dir, "m.mha", &bytes), 1 << 16);
    }
}
