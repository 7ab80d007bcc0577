//! `ercube vectors --stage pe`: one PE's sample stage (`ercube_pe_sample`)
//! over a frame as `$readmemh` files, a manifest and a plain Verilog
//! testbench (`pipeline::cosim::pe_vectors`), read from the capture of
//! `ercube cosim --stage pe`.

use anyhow::{anyhow, bail, Result};

use pipeline::cosim::pe_vectors::{capture, files::files, PeStream};

use super::cosim::{setup, Setup};
use super::vectors::VectorsArgs;

/// Words (rows times ports, and the memory writes) a run may write.
const MAX_WORDS: u64 = 50_000_000;

/// PE `pe`'s sample stage over the frame `s`: every port's word each
/// clock, the memory writes and the tables (`ercube vectors --stage pe`'s
/// files, in memory); refused in one line as the command refuses it.
pub fn stream(s: &Setup, pe: usize) -> Result<PeStream> {
    if s.units.lights.is_some() || s.units.voi {
        bail!("vectors --stage pe: the PE's vector files carry the plain sample only (no shading or volume of interest; `cosim --stage pe` runs the volume of interest)");
    }
    let dir = tempfile::Builder::new()
        .prefix("ercube-pe-vectors-")
        .tempdir()?;
    let st = capture(
        &|| s.frame(),
        &s.cfg,
        &s.prep.view,
        &s.module,
        pe,
        dir.path(),
    )
    .map_err(|e| anyhow!("vectors --stage pe: {e}"))?;
    let words = st.rows * st.columns.len() as u64 + st.writes.len() as u64;
    if words > MAX_WORDS {
        bail!(
            "vectors --stage pe: {} rows of {} ports and {} memory writes are {words} words, over {MAX_WORDS}; give a smaller frame (--size, --pes)",
            st.rows,
            st.columns.len(),
            st.writes.len()
        );
    }
    Ok(st)
}

/// Runs `ercube vectors --stage pe`.
pub fn run(a: &VectorsArgs) -> Result<()> {
    if a.cycles.is_some() {
        bail!("vectors --stage pe: --cycles is for the datapath's vectors (the PE's files run the whole frame: its memories carry state from the frame's start)");
    }
    let s = setup(&a.frame, "vectors")?;
    s.refuse_preint("vectors --stage pe", "written as vectors")?;
    let pe = a.pe.unwrap_or(0);
    let st = stream(&s, pe)?;
    let (files, _) = files(&st);
    let out = &a.out_dir;
    super::outputs::all_or_nothing(&[out], || {
        std::fs::create_dir_all(out)
            .map_err(|e| anyhow!("cannot create {}: {e}", out.display()))?;
        for (name, text) in &files {
            golden::image::write_atomic(&out.join(name), |w| w.write_all(text.as_bytes()))?;
        }
        Ok(())
    })?;
    super::say(&format!(
        "{}: PE {pe} of {}, {} samples of the frame's {} over {} cycles (the frame's {}), {} memory writes, {} files; manifest.json; pe_vectors_tb.v: iverilog -g2005 -o tb {}.v {}.v pe_vectors_tb.v && vvp -n tb",
        out.display(),
        st.pes,
        st.samples.0,
        st.samples.1,
        st.rows,
        st.frame_cycles,
        st.writes.len(),
        files.len(),
        st.datapath.0,
        pipeline::hw::pe_sample_rtl::MODULE,
    ));
    Ok(())
}
