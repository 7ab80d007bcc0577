//! Writes `demo.vcd` and `demo.gtkw` into the directory given as argument
//! (default: the current one), to look at the format in GTKWave:
//! `cargo run -p waves --example demo -- /tmp && gtkwave /tmp/demo.gtkw`.

use std::path::PathBuf;

use waves::{ScopePath, TraceConfig, Tracer};

fn main() -> Result<(), waves::WavesError> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    let mut tracer = Tracer::new(TraceConfig::new(dir.join("demo.vcd")))?;
    let state = tracer.register(&ScopePath::top().child("ctrl"), "state", 3)?;
    let pes: Vec<_> = (0..4)
        .map(|k| -> Result<_, waves::WavesError> {
            let pe = ScopePath::pe(k);
            Ok((
                tracer.register(&pe, "acc", 16)?,
                tracer.register(&pe, "valid", 1)?,
                tracer.register(&pe.child("mac"), "product", 24)?,
            ))
        })
        .collect::<Result<_, _>>()?;
    let mut acc = [0u64; 4];
    for cycle in 0..64u64 {
        tracer.sample(cycle, |s| {
            s.set(state, (cycle / 8) % 5);
            for (k, &(a, v, p)) in pes.iter().enumerate() {
                let product = (cycle * (k as u64 + 3)) & 0xff_ffff;
                acc[k] = (acc[k] + product) & 0xffff;
                s.set(a, acc[k]);
                s.set_bool(v, !(cycle + k as u64).is_multiple_of(4));
                s.set(p, product);
            }
        });
    }
    let info = tracer.finish()?.expect("tracing is on");
    info.write_gtkw(dir.join("demo.gtkw"))?;
    println!("wrote {} and demo.gtkw", info.dump_path().display());
    Ok(())
}
