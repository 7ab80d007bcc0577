//! Selection (PEs, cycle window, signal names), error handling and the
//! disabled tracer.

use std::cell::Cell;
use std::path::Path;

use waves::{PeFilter, ScopePath, SignalId, Trace, TraceConfig, Tracer, WavesError};

/// A model with 4 PEs (`acc` 16 bits, `valid` 1 bit) and a controller
/// `state`; every value is a function of (cycle, PE) so a test can recompute it.
fn acc(cycle: u64, k: u32) -> u64 {
    (cycle * 7 + u64::from(k) * 1000) & 0xffff
}

fn run_model(config: TraceConfig, cycles: u64) -> Result<Option<waves::TraceInfo>, WavesError> {
    let mut t = Tracer::new(config)?;
    let ctrl = ScopePath::top().child("ctrl");
    let state = t.register(&ctrl, "state", 3)?;
    let mut ids = Vec::new();
    for k in 0..4 {
        ids.push((
            t.register(&ScopePath::pe(k), "acc", 16)?,
            t.register(&ScopePath::pe(k), "valid", 1)?,
        ));
    }
    for c in 0..cycles {
        t.sample(c, |s| {
            s.set(state, c % 5);
            for (k, &(a, v)) in ids.iter().enumerate() {
                s.set(a, acc(c, k as u32));
                s.set_bool(v, (c + k as u64).is_multiple_of(3));
            }
        });
    }
    t.finish()
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn pe_filter_and_window_write_only_the_selection() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.vcd");
    let config = TraceConfig::new(&path)
        .with_pes(PeFilter::Only([1, 3].into()))
        .with_cycles(5..=9);
    let info = run_model(config, 20).unwrap().unwrap();
    assert_eq!(info.cycles, Some(5..=9));
    let names: Vec<String> = info.signals.iter().map(|s| s.full_name()).collect();
    assert_eq!(
        names,
        [
            "top.clk",
            "top.ctrl.state",
            "top.pe_1.acc",
            "top.pe_1.valid",
            "top.pe_3.acc",
            "top.pe_3.valid"
        ]
    );

    let trace = Trace::read(&path).unwrap();
    let mut read_names: Vec<&str> = trace.names().collect();
    read_names.sort();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(read_names, sorted, "PEs 0 and 2 must not be in the file");
    let unit = waves::TIME_UNITS_PER_CYCLE;
    assert_eq!(trace.end_time(), 10 * unit);
    for name in &names {
        let sig = trace.signal(name).unwrap();
        assert!(!sig.changes().is_empty(), "{name}");
        for ch in sig.changes() {
            assert!(
                (5 * unit..=10 * unit - unit / 2).contains(&ch.time),
                "{name} record at {}",
                ch.time
            );
        }
        // Nothing before the window, not even a value carried over.
        assert_eq!(sig.value_at_cycle(4), None, "{name}");
    }
    for k in [1, 3] {
        let a = trace.signal(&format!("top.pe_{k}.acc")).unwrap();
        let v = trace.signal(&format!("top.pe_{k}.valid")).unwrap();
        for c in 5..=9 {
            assert_eq!(a.u64_at_cycle(c), Some(acc(c, k)), "pe {k} cycle {c}");
            assert_eq!(
                v.u64_at_cycle(c),
                Some(u64::from((c + u64::from(k)) % 3 == 0))
            );
        }
        // The window's first cycle is a full dump even though `valid`
        // was already false in cycle 4; later only changes.
        let changes = v.changes().iter().map(|c| c.cycle()).collect::<Vec<_>>();
        let mut expected = vec![5];
        expected.extend((6..=9).filter(|c| (c + u64::from(k)) % 3 <= 1));
        assert_eq!(changes, expected, "pe {k}");
    }
    let state = trace.signal("top.ctrl.state").unwrap();
    assert_eq!(
        state
            .changes()
            .iter()
            .map(|c| c.cycle())
            .collect::<Vec<_>>(),
        [5, 6, 7, 8, 9]
    );
}

#[test]
fn signal_globs_select_by_leaf_or_full_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.vcd");
    let config = TraceConfig::new(&path)
        .with_signals(["valid", "top.pe_2.*"])
        .with_clock(false);
    let info = run_model(config, 6).unwrap().unwrap();
    let names: Vec<String> = info.signals.iter().map(|s| s.full_name()).collect();
    assert_eq!(
        names,
        [
            "top.pe_0.valid",
            "top.pe_1.valid",
            "top.pe_2.acc",
            "top.pe_2.valid",
            "top.pe_3.valid"
        ]
    );
    let trace = Trace::read(&path).unwrap();
    assert_eq!(trace.names().count(), 5);
    assert_eq!(
        trace.signal("top.pe_2.acc").unwrap().u64_at_cycle(3),
        Some(acc(3, 2))
    );
}

#[test]
fn empty_window_writes_a_header_only() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("e.vcd");
    let info = run_model(TraceConfig::new(&path).with_cycles(100..=200), 20)
        .unwrap()
        .unwrap();
    assert_eq!(info.cycles, None);
    let trace = Trace::read(&path).unwrap();
    assert_eq!(trace.names().count(), 10);
    assert!(trace
        .names()
        .all(|n| trace.signal(n).unwrap().changes().is_empty()));
}

#[test]
fn disabled_or_outside_window_never_calls_the_closure() {
    let calls = Cell::new(0);
    let mut off = Tracer::disabled();
    assert!(!off.is_enabled());
    let id = off.register(&ScopePath::pe(0), "acc", 8).unwrap();
    assert_eq!(id, SignalId::NONE);
    for c in 0..1000 {
        off.sample(c, |_| calls.set(calls.get() + 1));
    }
    assert_eq!(calls.get(), 0);
    assert!(off.finish().unwrap().is_none());

    let dir = tempfile::tempdir().unwrap();
    let mut t =
        Tracer::new(TraceConfig::new(dir.path().join("w.vcd")).with_cycles(10..=12)).unwrap();
    for c in 0..1000 {
        t.sample(c, |s| {
            assert_eq!(s.cycle(), c);
            calls.set(calls.get() + 1)
        });
    }
    assert_eq!(calls.get(), 3);
    assert!(!t.is_active(9) && t.is_active(10) && t.is_active(12) && !t.is_active(13));
}

#[test]
fn registration_errors_even_when_disabled() {
    let dir = tempfile::tempdir().unwrap();
    for mut t in [
        Tracer::disabled(),
        Tracer::new(TraceConfig::new(dir.path().join("reg.vcd"))).unwrap(),
    ] {
        let pe = ScopePath::pe(0);
        t.register(&pe, "acc", 8).unwrap();
        assert!(
            matches!(t.register(&pe, "acc", 4), Err(WavesError::DuplicateSignal(n)) if n == "top.pe_0.acc")
        );
        assert!(matches!(
            t.register(&pe, "x", 0),
            Err(WavesError::InvalidWidth { .. })
        ));
        assert!(matches!(
            t.register(&pe, "x", waves::MAX_WIDTH + 1),
            Err(WavesError::InvalidWidth { .. })
        ));
        assert!(matches!(
            t.register(&pe, "a.b", 1),
            Err(WavesError::InvalidName(_))
        ));
        assert!(matches!(
            t.register(&pe, "a[0]", 1),
            Err(WavesError::InvalidName(_))
        ));
        assert!(matches!(
            t.register(&ScopePath::top().child("bad scope"), "a", 1),
            Err(WavesError::InvalidName(_))
        ));
        if t.is_enabled() {
            assert!(matches!(
                t.register(&ScopePath::top(), "clk", 1),
                Err(WavesError::DuplicateSignal(_))
            ));
        }
        // Not finished: an enabled tracer leaves no file behind.
    }
    assert_eq!(files_in(dir.path()), Vec::<String>::new());
}

#[test]
fn late_registration_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Tracer::new(TraceConfig::new(dir.path().join("l.vcd"))).unwrap();
    t.sample(0, |_| {});
    assert!(matches!(
        t.register(&ScopePath::top(), "late", 1),
        Err(WavesError::LateRegistration(_))
    ));
}

/// Runs one bad sample; the error must come out of `finish`, tracing must
/// stop at it, and neither the trace nor a temporary file may remain.
fn expect_sample_error(f: impl Fn(&mut Tracer, &[SignalId])) -> WavesError {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.vcd");
    let mut t = Tracer::new(TraceConfig::new(&path)).unwrap();
    let ids = [
        t.register(&ScopePath::pe(0), "b", 8).unwrap(),
        t.register(&ScopePath::pe(0), "s", 4).unwrap(),
        t.register(&ScopePath::pe(0), "w", 70).unwrap(),
    ];
    t.sample(0, |s| s.set(ids[0], 1));
    assert!(t.error().is_none());
    f(&mut t, &ids);
    assert!(t.error().is_some());
    assert!(!t.is_active(11), "tracing must stop after an error");
    let e = t.finish().unwrap_err();
    assert_eq!(files_in(dir.path()), Vec::<String>::new());
    e
}

#[test]
fn values_that_do_not_fit_are_errors() {
    let e = expect_sample_error(|t, ids| t.sample(3, |s| s.set(ids[0], 0x100)));
    assert!(
        matches!(&e, WavesError::ValueTooWide { signal, width: 8, cycle: 3, .. } if signal == "top.pe_0.b")
    );
    assert_eq!(
        e.to_string(),
        "signal top.pe_0.b (8 bits) at cycle 3: value 0x100 does not fit"
    );
    for bad in [8i64, -9] {
        let e = expect_sample_error(|t, ids| t.sample(3, |s| s.set_signed(ids[1], bad)));
        assert!(
            matches!(e, WavesError::ValueTooWide { width: 4, .. }),
            "{bad}"
        );
    }
    let e = expect_sample_error(|t, ids| {
        let mut bits = waves::bitvec::bitvec![u8, waves::bitvec::order::Lsb0; 0; 71];
        bits.set(70, true);
        t.sample(3, |s| s.set_bits(ids[2], &bits));
    });
    assert!(e.to_string().contains("bit 70"), "{e}");
    let e = expect_sample_error(|t, _| {
        t.sample(10, |_| {});
        t.sample(5, |_| {});
    });
    assert!(matches!(
        e,
        WavesError::CycleWentBackwards {
            cycle: 5,
            previous: 10
        }
    ));
}

#[test]
fn signed_and_wide_values_in_range_are_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.vcd");
    let mut t = Tracer::new(TraceConfig::new(&path)).unwrap();
    let s4 = t.register(&ScopePath::top(), "s4", 4).unwrap();
    let s70 = t.register(&ScopePath::top(), "s70", 70).unwrap();
    let u70 = t.register(&ScopePath::top(), "u70", 70).unwrap();
    let vals = [-8i64, 7, -1, 0];
    for (c, &v) in vals.iter().enumerate() {
        t.sample(c as u64, |s| {
            s.set_signed(s4, v);
            s.set_signed(s70, v);
            s.set(u70, v as u64);
        });
    }
    t.finish().unwrap();
    let trace = Trace::read(&path).unwrap();
    for (c, &v) in vals.iter().enumerate() {
        let c = c as u64;
        assert_eq!(
            trace.signal("top.s4").unwrap().u64_at_cycle(c),
            Some(v as u64 & 0xf)
        );
        let wide = trace
            .signal("top.s70")
            .unwrap()
            .value_at_cycle(c)
            .unwrap()
            .to_string();
        let sign = if v < 0 { "111111" } else { "000000" };
        assert_eq!(wide, format!("{sign}{:064b}", v as u64), "cycle {c}");
        let u = trace.signal("top.u70").unwrap().value_at_cycle(c).unwrap();
        assert_eq!(u.to_string(), format!("000000{:064b}", v as u64));
    }
}

#[test]
fn io_errors_name_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no/such/dir/t.vcd");
    let e = Tracer::new(TraceConfig::new(&missing)).unwrap_err();
    assert!(matches!(e, WavesError::Io { .. }));
    assert!(e.to_string().contains("no/such/dir"), "{e}");

    // The final rename fails when the target is a non-empty directory.
    let target = dir.path().join("occupied.vcd");
    std::fs::create_dir(&target).unwrap();
    std::fs::write(target.join("keep"), "x").unwrap();
    let e = run_model(TraceConfig::new(&target), 3).unwrap_err();
    assert!(matches!(e, WavesError::Io { .. }));
    assert!(e.to_string().contains("occupied.vcd"), "{e}");
    assert_eq!(
        files_in(dir.path()),
        ["occupied.vcd"],
        "temporary file left behind"
    );
}

/// An FST's header starts at the first traced cycle, not at 0, so a
/// viewer's full zoom shows the traced window and nothing before it.
#[test]
fn the_fst_header_starts_at_the_first_traced_cycle() {
    let dir = tempfile::tempdir().unwrap();
    let fst = dir.path().join("w.fst");
    let config = TraceConfig::new_fst(&fst).with_cycles(5..=9);
    run_model(config, 20).unwrap().unwrap();
    let bytes = std::fs::read(&fst).unwrap();
    // FST header block: type 0, section length, then start and end time
    // (big-endian u64).
    assert_eq!(bytes[0], 0, "header block first");
    let word = |at: usize| u64::from_be_bytes(bytes[at..at + 8].try_into().unwrap());
    let unit = waves::TIME_UNITS_PER_CYCLE;
    assert_eq!(word(9), 5 * unit, "start time");
    assert_eq!(word(17), 10 * unit, "end time");
}

/// The marker signal's first change into each value, and every change
/// into an `always` value, become named markers (26 at most).
#[test]
fn marker_signal_changes_become_named_markers() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.vcd");
    let mut t = Tracer::new(TraceConfig::new(&path).with_markers("top.ctrl.state", [3])).unwrap();
    let group = waves::Group {
        name: "ctrl",
        default: true,
    };
    let names = [(0, "idle"), (3, "merge")];
    let state = t
        .register_enum_in(&group, &ScopePath::top().child("ctrl"), "state", 3, &names)
        .unwrap();
    // 0 0 1 3 0 1 3 0 ...: each value's first start, and every 3.
    for c in 0..40u64 {
        let v = [0, 0, 1, 3, 0, 1, 3, 0][c as usize % 8];
        t.sample(c, |s| s.set(state, v));
    }
    let info = t.finish().unwrap().unwrap();
    let want: Vec<(u64, String)> = std::iter::once((0, "idle".to_string()))
        .chain(std::iter::once((2, "1".to_string())))
        .chain((0..5).flat_map(|k| {
            [
                (8 * k + 3, "merge".to_string()),
                (8 * k + 6, "merge".into()),
            ]
        }))
        .filter(|(c, _)| *c < 40)
        .collect();
    assert_eq!(info.markers, want);
    let text = std::fs::read_to_string(dir.path().join("m.gtkw")).unwrap_or_default();
    assert!(text.is_empty(), "the tracer writes no save file by itself");
    info.write_gtkw(dir.path().join("m.gtkw")).unwrap();
    let text = std::fs::read_to_string(dir.path().join("m.gtkw")).unwrap();
    assert!(
        text.contains("[markername] Aidle\n[markername] B1\n[markername] Cmerge\n"),
        "{text}"
    );
}

/// A VCD and an FST of one trace each get their own save file, each
/// opening its own dump.
#[test]
fn vcd_and_fst_of_one_name_get_their_own_save_files() {
    let dir = tempfile::tempdir().unwrap();
    let (vcd, fst) = (dir.path().join("x.vcd"), dir.path().join("x.fst"));
    let info = run_model(TraceConfig::new(&vcd).with_fst(&fst), 4)
        .unwrap()
        .unwrap();
    let files = info.save_files();
    assert_eq!(
        files,
        [
            (dir.path().join("x.gtkw"), vcd.clone()),
            (dir.path().join("x.fst.gtkw"), fst.clone())
        ]
    );
}
