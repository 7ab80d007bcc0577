//! The command line: argument parsing, dispatch and the one-line error
//! contract (every failure prints `ercube: error: ...` on one line and exits
//! with status 2; nothing panics on bad input).

mod animate;
pub(crate) mod args;
mod bench;
mod bound;
mod chip;
mod compare;
mod cosim;
pub(crate) mod cosim_frame;
mod cosim_pass;
mod cosim_pe;
mod cost;
mod explore;
mod memory;
mod method;
mod montage;
mod outputs;
mod pass;
mod peer;
mod plot;
mod progress;
mod refine;
pub(crate) mod render;
mod rtl;
mod rtl_pass;
mod rtl_pe;
mod skipbench;
mod stats;
mod synth;
mod vectors;
pub(crate) mod vectors_pe;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// ercube: a cycle- and bit-accurate model of a Cube-style perspective
/// volume-rendering chip (ER-Perspective), beside its float golden model.
/// Render and compare methods (render, compare, demo, animate), benchmark
/// them (bench, merge-results, skip-bench, peer), and size the chip
/// (cost, explore, sweep-widths).
#[derive(Debug, Parser)]
#[command(name = "ercube", version, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Render one image of a scene or volume file with one method.
    Render(Box<render::RenderArgs>),
    /// Render with several methods, write each image, a labelled montage
    /// and a table of time, samples and error against the reference.
    Compare(Box<compare::CompareArgs>),
    /// Compare every method on the embedded default scene (no files needed).
    Demo(compare::DemoArgs),
    /// Render a camera path (an orbit or a file of eyes) frame by frame,
    /// reusing what the camera does not change; PNG frames and a GIF.
    Animate(Box<animate::AnimateArgs>),
    /// Time every method over a sweep of eye distances against the
    /// reference; write a CSV, plots and a summary (or, with --report DIR,
    /// the whole benchmark report).
    Bench(Box<bench::BenchArgs>),
    /// Join the shard files of a `bench --shard K/N` sweep into the CSV,
    /// plots and summary the unsharded run writes.
    MergeResults(Box<bench::MergeArgs>),
    /// Run the pipeline over a grid of datapath widths and write its error
    /// against golden er beside the total datapath bits.
    SweepWidths(Box<bench::SweepArgs>),
    /// FPGA cost of the PE array: resources per PE and in all, fit on
    /// real parts, frame rate and voxel bandwidth from a pipeline run.
    Cost(Box<cost::CostArgs>),
    /// Sweep mappings x ray-buffer placements x PE counts (x cyclic
    /// widths) on one view: measured cycles, resources, memory, external
    /// bandwidth, frames/s and the parts each fits; a table and a plot.
    Explore(Box<explore::ExploreArgs>),
    /// Render one view with ercube's methods and with a peer renderer
    /// (VTK), timing each and comparing it with ercube's reference;
    /// write a table, an error-against-time plot and the images.
    Peer(Box<peer::PeerArgs>),
    /// Measure what each kind of skipping saves (golden time, pipeline
    /// cycles) on four scenes; write the "Skipping" section of the report.
    SkipBench(Box<skipbench::SkipBenchArgs>),
    /// Progressive refinement of a resting view (reference or mipmap):
    /// steps each adding rays, none cast twice, ending on one ray per
    /// pixel; each step's PNG and its error over cumulative time.
    Refine(Box<refine::RefineArgs>),
    /// Synthesize a unit of the PE and place and route it on an FPGA part
    /// (yosys, nextpnr): measured resources, clock and critical path beside
    /// the estimate.
    Synth(Box<synth::SynthArgs>),
    /// Write the PE's sample datapath as pipelined Verilog (with a file
    /// list and a README naming every port).
    Rtl(Box<rtl::RtlArgs>),
    /// Run a frame in the model and, replayed from it, in the emitted
    /// Verilog of every PE's datapath (Verilator or Icarus); compare every
    /// output on every cycle (exit status 1 on a mismatch).
    Cosim(Box<cosim::CosimArgs>),
    /// Write a frame's per-PE, per-port stimulus and expected responses
    /// of the datapath as $readmemh files, a JSON manifest and a plain
    /// Verilog testbench.
    Vectors(Box<vectors::VectorsArgs>),
}

/// Prints a line to stdout; a closed pipe (`ercube ... | head`) is not an
/// error worth a panic, so write failures are ignored.
pub fn say(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stdout().lock(), "{line}");
}

/// A clap error on one line: clap spreads one error over several lines
/// (the message, the arguments it names, a usage line); this keeps all but
/// the usage.
pub(crate) fn one_line(e: &clap::Error) -> String {
    let text = e.to_string();
    let msg: Vec<&str> = text
        .lines()
        .map(str::trim)
        .take_while(|l| !l.starts_with("Usage:"))
        .filter(|l| !l.is_empty() && !l.starts_with("For more information"))
        .collect();
    msg.join(" ").trim_start_matches("error: ").to_string()
}

/// Parses the command line and runs it.
pub fn run() -> ExitCode {
    run_with(std::env::args_os())
}

/// Runs the command line `args` (the program's name first), as `main`
/// runs the process's: prints what the command prints, writes its files
/// and returns its exit status.
pub fn run_with<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                let _ = e.print();
                return if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                    ExitCode::from(2)
                } else {
                    ExitCode::SUCCESS
                };
            }
            eprintln!("ercube: error: {} (see ercube --help)", one_line(&e));
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Render(a) => render::run(&a),
        Command::Compare(a) => compare::run(&a),
        Command::Demo(a) => compare::demo(&a),
        Command::Animate(a) => animate::run(&a),
        Command::Cost(a) => cost::run(&a),
        Command::Explore(a) => explore::run(&a),
        Command::Bench(a) => bench::run(&a),
        Command::MergeResults(a) => bench::merge_results(&a),
        Command::SweepWidths(a) => bench::sweep_widths(&a),
        Command::SkipBench(a) => skipbench::run(&a),
        Command::Peer(a) => peer::run(&a),
        Command::Refine(a) => refine::run(&a),
        Command::Synth(a) => synth::run(&a),
        Command::Rtl(a) => rtl::run(&a),
        Command::Cosim(a) => cosim::run(&a),
        Command::Vectors(a) => vectors::run(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<cosim::Mismatched>() => {
            eprintln!("ercube: {e}");
            ExitCode::from(1)
        }
        Err(e) => {
            let msg = format!("{e:#}");
            eprintln!("ercube: error: {}", msg.replace('\n', " "));
            ExitCode::from(2)
        }
    }
}
