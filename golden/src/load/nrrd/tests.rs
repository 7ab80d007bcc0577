//! Unit tests of the NRRD loader: header parsing, data layouts, bad and
//! random input.

use super::*;
use crate::load::tests::{assert_err, assert_headers_refused, gzip, u16_data, write};
use crate::volume::{VoxelType, DEFAULT_MEMORY_LIMIT};
use proptest::prelude::*;

const LIM: u64 = DEFAULT_MEMORY_LIMIT;

/// A 4x3x2 header with `extra` fields appended.
fn header(ty: &str, enc: &str, extra: &str) -> String {
    format!(
        "NRRD0004\n# a comment\ntype: {ty}\ndimension: 3\nsizes: 4 3 2\nencoding: {enc}\n{extra}"
    )
}

fn lines(text: &str) -> Vec<String> {
    text.lines().map(str::to_owned).collect()
}

fn parse(text: &str) -> std::result::Result<Header, String> {
    parse_header(&lines(text))
}

#[test]
fn nrrd_header_fields_spellings_and_placement() {
    let h = parse(&header(
        "unsigned short",
        "gz",
        "endian: big\nspace: RAS\nspace directions: (0,2,0) ( 0.5, 0, 0 ) (0,0,-3)\n\
         space origin: (1,2,3)\nkey:=value: with: colons\nByteSkip: 5\nline skip: 2\n\
         kinds: domain domain domain\nunknown field: ignored\n",
    ))
    .unwrap();
    assert_eq!(
        (h.dims, h.scalar, h.encoding, h.big),
        ([4, 3, 2], Scalar::U16, Encoding::Gzip, true)
    );
    assert_eq!(h.spacing, [2.0, 0.5, 3.0]);
    // Kept in LPS: the RAS space's x and y change sign.
    assert_eq!(
        h.axes,
        Some([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    );
    assert_eq!(h.origin, Some([-1.0, -2.0, 3.0]));
    assert_eq!((h.byte_skip, h.line_skip, h.data_file), (5, 2, None));
    // Per-axis spacings, each within the one spacing rule.
    let h = parse(&header("int8", "raw", "spacings: 0.5 2 1\n")).unwrap();
    assert_eq!(
        (h.scalar, h.spacing, h.axes),
        (Scalar::I8, [0.5, 2.0, 1.0], None)
    );
    for bad in ["nan 2 1", "1 -2 1", "1 2 0", "1e-150 1 1"] {
        let e = parse(&header("int8", "raw", &format!("spacings: {bad}\n"))).unwrap_err();
        assert!(
            e.contains("spacings") && e.contains("is not a voxel spacing"),
            "{e}"
        );
    }
    // Type, encoding and endian names in any case.
    let h = parse(&header("Unsigned Char", "RAW", "endian: Big\n")).unwrap();
    assert_eq!(
        (h.scalar, h.encoding, h.big),
        (Scalar::U8, Encoding::Raw, true)
    );
    // A 4D NRRD with a trailing axis of size 1, one 'none' direction.
    let text = "NRRD0005\ntype: float\ndimension: 4\nsizes: 4 3 2 1\nencoding: raw\n\
                endian: little\nspace dimension: 3\n\
                space directions: (1,0,0) (0,1,0) (0,0,1) none\ndata file: x.raw\n";
    let h = parse(text).unwrap();
    assert_eq!((h.dims, h.data_file.as_deref()), ([4, 3, 2], Some("x.raw")));
}

#[test]
fn bad_nrrd_headers_are_refused() {
    let u8h = |extra: &str| header("uint8", "raw", extra);
    let cases: Vec<(String, &str)> = vec![
        ("NRRD0009\ntype: uint8".into(), "not a NRRD file"),
        ("P5 12 10".into(), "not a NRRD file"),
        (u8h("type: uint8\n"), "'type' is given twice"),
        (
            u8h("just words\n"),
            "line 7 'just words' is not 'field: value'",
        ),
        (header("block", "raw", ""), "unsupported NRRD type 'block'"),
        (header("uint64", "raw", ""), "unsupported NRRD type"),
        (
            header("uint8", "bzip2", ""),
            "unsupported NRRD encoding 'bzip2'",
        ),
        (header("uint16", "raw", ""), "'endian' is required"),
        (
            header("uint16", "raw", "endian: middle\n"),
            "endian 'middle'",
        ),
        (
            "NRRD0004\ntype: uint8\nsizes: 4 3 2\nencoding: raw".into(),
            "'dimension' is missing",
        ),
        (u8h("").replace("sizes: 4 3 2\n", ""), "'sizes' is missing"),
        (
            u8h("").replace("sizes: 4 3 2", "sizes: 4 3"),
            "has 2 values, 3 expected",
        ),
        (
            u8h("").replace("sizes: 4 3 2", "sizes: 4 -3 2"),
            "not a list of numbers",
        ),
        (
            u8h("").replace("dimension: 3", "dimension: 2"),
            "dimension 2: only 3D",
        ),
        (
            u8h("").replace("dimension: 3", "dimension: 99"),
            "dimension 99",
        ),
        (
            u8h("").replace("dimension: 3\nsizes: 4 3 2", "dimension: 4\nsizes: 4 3 2 5"),
            "a 4D image, axis 3 has 5",
        ),
        (
            u8h("spacings: 1 1 1\nspace: RAS\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n"),
            "both",
        ),
        (
            u8h("space directions: (1,0,0) (0,1,0) (0,0,1)\n"),
            "needs 'space'",
        ),
        (
            u8h("space: RAS\nspace directions: (1,0) (0,1,0) (0,0,1)\n"),
            "2 components",
        ),
        (
            u8h("space: RAS\nspace directions: (1,0,0) (0,1,0)\n"),
            "2 vectors, 3 expected",
        ),
        (
            u8h("space: RAS\nspace directions: (1,0,0) (0,1,0) (0,0,1\n"),
            "not closed",
        ),
        (
            u8h("space: RAS\nspace directions: (1,0,0) (0,x,0) (0,0,1)\n"),
            "not a number",
        ),
        (
            u8h("space: RAS\nspace directions: [1,0,0]\n"),
            "expected '(' or 'none'",
        ),
        (u8h("space: mars\n"), "unknown NRRD space 'mars'"),
        (u8h("space: RAS\nspace dimension: 3\n"), "both 'space' and"),
        (u8h("space dimension: 0\n"), "space dimension '0'"),
        (u8h("space origin: (1,2,3)\n"), "needs 'space'"),
        (u8h("spacings: 1 1\n"), "has 2 values"),
        (u8h("byte skip: -2\n"), "byte skip '-2'"),
        (u8h("line skip: -1\n"), "line skip '-1'"),
        (
            header("uint8", "gzip", "byte skip: -1\n"),
            "needs raw encoding",
        ),
        (u8h("data file: LIST\n"), "only a single data file"),
        (
            u8h("data file: slice%03d.raw 1 10 1\n"),
            "only a single data file",
        ),
    ];
    assert_headers_refused(&cases, parse);
}

#[test]
fn nrrd_attached_raw_and_gzip_with_skips() {
    let dir = tempfile::tempdir().unwrap();
    let (vals, be) = u16_data(true);
    let skipped = [b"two\nlines\n".as_slice(), &[9; 3], &be].concat();
    let h = header(
        "uint16",
        "raw",
        "endian: big\nline skip: 2\nbyte skip: 3\nspacings: 1 2 3\n",
    );
    let path = write(
        &dir,
        "a.nrrd",
        &[format!("{h}\n").as_bytes(), &skipped].concat(),
    );
    let l = read_nrrd(&path, LIM).unwrap();
    assert_eq!(
        (l.volume.kind(), &*l.volume.data()),
        (VoxelType::U16, &vals[..])
    );
    assert_eq!(
        (l.volume.spacing(), l.origin, l.axes),
        ([1.0, 2.0, 3.0], None, None)
    );
    // Trailing bytes are accepted; byte skip -1 takes the end of the file.
    let h = header("uint16", "raw", "endian: big\nbyte skip: -1\n");
    let path = write(
        &dir,
        "b.nrrd",
        &[format!("{h}\n").as_bytes(), &[7; 5], &be].concat(),
    );
    assert_eq!(load_nrrd(&path, LIM).unwrap().data(), &vals[..]);
    // gzip: line skip before inflating, byte skip inside the stream.
    let (_, le) = u16_data(false);
    let h = header(
        "uint16",
        "gzip",
        "endian: little\nline skip: 1\nbyte skip: 4\n",
    );
    let body = [
        b"skip me\n".as_slice(),
        &gzip(&[&[1, 2, 3, 4], &le[..]].concat()),
    ]
    .concat();
    let path = write(
        &dir,
        "c.nrrd",
        &[format!("{h}\n").as_bytes(), &body].concat(),
    );
    assert_eq!(load_nrrd(&path, LIM).unwrap().data(), &vals[..]);
}

#[test]
fn nrrd_detached_data_file() {
    let dir = tempfile::tempdir().unwrap();
    let (vals, le) = u16_data(false);
    write(&dir, "d.raw.gz", &gzip(&le));
    let h = header("ushort", "gzip", "endian: little\ndata file: d.raw.gz\n");
    let path = write(&dir, "d.nhdr", h.as_bytes());
    assert_eq!(load_nrrd(&path, LIM).unwrap().data(), &vals[..]);
    let h = header("ushort", "raw", "endian: little\ndatafile: missing.raw\n");
    assert_err(
        load_nrrd(&write(&dir, "e.nhdr", h.as_bytes()), LIM),
        "missing.raw",
    );
    // No blank line and no data file: nowhere to find the data.
    let h = header("uint8", "raw", "");
    assert_err(
        load_nrrd(&write(&dir, "f.nrrd", h.as_bytes()), LIM),
        "blank line",
    );
}

#[test]
fn truncated_or_absurd_nrrd_data_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (_, le) = u16_data(false);
    let h = format!("{}\n", header("uint16", "raw", "endian: little\n"));
    let file = [h.as_bytes(), &le[..40]].concat();
    assert_err(
        load_nrrd(&write(&dir, "a.nrrd", &file), LIM),
        &format!(
            "truncated: expected 48 bytes of voxel data at offset {}, found 40",
            h.len()
        ),
    );
    let h = format!("{}\n", header("uint16", "gzip", "endian: little\n"));
    let file = [h.as_bytes(), &gzip(&le[..40])].concat();
    assert_err(load_nrrd(&write(&dir, "b.nrrd", &file), LIM), "truncated");
    let gz = gzip(&le);
    let file = [h.as_bytes(), &gz[..gz.len() - 10]].concat();
    assert_err(
        load_nrrd(&write(&dir, "c.nrrd", &file), LIM),
        "unreadable data",
    );
    let h = format!("{}\n", header("uint8", "raw", "line skip: 3\n"));
    let file = [h.as_bytes(), b"one\n"].concat();
    assert_err(
        load_nrrd(&write(&dir, "d.nrrd", &file), LIM),
        "line skip 3 passes the end",
    );
    // Huge sizes in a tiny file: refused before allocating.
    let h = header("double", "raw", "endian: little\n").replace("4 3 2", "8000 8000 8000");
    assert_err(
        load_nrrd(&write(&dir, "e.nrrd", format!("{h}\n").as_bytes()), LIM),
        "over the memory limit",
    );
    let h = header("uint8", "raw", "").replace("4 3 2", "4 0 2");
    assert_err(
        load_nrrd(&write(&dir, "f.nrrd", format!("{h}\n").as_bytes()), LIM),
        "zero",
    );
    let h = header("uint8", "raw", "").replace("4 3 2", "99999 1 1");
    assert_err(
        load_nrrd(&write(&dir, "g.nrrd", format!("{h}\n").as_bytes()), LIM),
        "absurd",
    );
    // A binary file with no newline is not read past the header cap.
    assert_err(
        load_nrrd(&write(&dir, "h.nrrd", &[b'N'; 1 << 21]), LIM),
        "not a NRRD",
    );
    let mut long = b"NRRD0004\n".to_vec();
    long.extend(vec![b'#'; 1 << 21]);
    assert_err(
        load_nrrd(&write(&dir, "i.nrrd", &long), LIM),
        "runs past 1048576 bytes",
    );
}

/// Header lines of random fields, values and junk.
fn random_line() -> impl Strategy<Value = String> {
    let name = prop::sample::select(vec![
        "type",
        "dimension",
        "sizes",
        "encoding",
        "endian",
        "spacings",
        "space",
        "space dimension",
        "space directions",
        "space origin",
        "byte skip",
        "line skip",
        "data file",
        "kinds",
    ]);
    let value = prop::sample::select(vec![
        "uint8",
        "int16",
        "float",
        "double",
        "raw",
        "gzip",
        "little",
        "big",
        "3",
        "4",
        "-1",
        "0",
        "4 3 2",
        "1 1 1",
        "nan 1 1",
        "RAS",
        "(1,0,0) (0,1,0) (0,0,1)",
        "(1,0) none",
        "(1,2,3)",
        "LIST",
        "x%d 1 2 3",
        "((",
        ")",
        "",
    ]);
    prop_oneof![
        (name, value).prop_map(|(n, v)| format!("{n}: {v}")),
        "[ -~]{0,30}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Random headers without the required fields are errors, never panics.
    #[test]
    fn random_nrrd_headers_are_refused(body in prop::collection::vec(random_line(), 0..12)) {
        let mut text = vec!["NRRD0004".to_owned()];
        let required = |l: &&String| l.starts_with("type") || l.starts_with("sizes");
        text.extend(body.iter().filter(|l| !required(l)).cloned());
        prop_assert!(parse_header(&text).is_err());
        // With the fields present anything may happen, but no panic.
        text.push("type: uint8".into());
        text.push("sizes: 4 3 2".into());
        let _ = parse_header(&text);
    }

    /// Mutated NRRD files (header and data) load or fail, never panic.
    #[test]
    fn mutated_nrrd_files_never_panic(
        gz in any::<bool>(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let (_, le) = u16_data(false);
        let enc = if gz { "gzip" } else { "raw" };
        let h = format!("{}\n", header("uint16", enc, "endian: little\nspacings: 1 1 1\n"));
        let mut bytes = [h.as_bytes(), &if gz { gzip(&le) } else { le }].concat();
        for (at, b) in edits {
            let i = at.index(bytes.len());
            bytes[i] = b;
        }
        let _ = load_nrrd(&write(&dir, "m.nrrd", &bytes), 1 << 16);
    }
}
