//! The methods a command line names: the golden model's techniques and the
//! PE array in its two orders, one enum for `render --method`, `compare
//! --methods` and `bench --methods`, so no method is spelled as a string
//! anywhere else.

use clap::ValueEnum;
use golden::methods::Method;
use golden::render::Technique;
use pipeline::config::Order;

/// A rendering method (clap spells each variant in kebab case:
/// `er-ftb`, `pipeline-ftb`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// The supersampled image-order ray caster in f64.
    Reference,
    /// ER-Perspective, back to front.
    Er,
    /// ER-Perspective, front to back with early ray termination.
    ErFtb,
    /// One region of rays one voxel apart at the front.
    Under,
    /// One region of rays one voxel apart at the last slice.
    Over,
    /// ER with a 2x2 box merge.
    Box,
    /// Ray casting a pre-classified 3D mip-map, the level following each
    /// ray's footprint.
    Mipmap,
    /// Perspective shear-warp: slices sheared onto an intermediate image,
    /// composited front to back, then warped.
    ShearWarp,
    /// The bit-accurate PE array, back to front (mirrors `er`).
    Pipeline,
    /// The PE array front to back with termination (mirrors `er-ftb`).
    PipelineFtb,
}

impl MethodArg {
    /// The name on the command line and in tables, plots and stats.
    pub fn name(self) -> &'static str {
        match self {
            MethodArg::Reference => "reference",
            MethodArg::Pipeline => "pipeline",
            MethodArg::PipelineFtb => "pipeline-ftb",
            m => m.technique().map_or("", Technique::name),
        }
    }

    /// Parses a name as clap does (exact, case-sensitive).
    pub fn parse(name: &str) -> Option<MethodArg> {
        MethodArg::from_str(name, false).ok()
    }

    /// The method a table or plot label names: a method's name, or
    /// `pipeline:STEM` for the PE array with a configuration file.
    pub fn of_label(label: &str) -> Option<MethodArg> {
        match label.split_once(':') {
            Some((m, _)) => MethodArg::parse(m).filter(|m| *m == MethodArg::Pipeline),
            None => MethodArg::parse(label),
        }
    }

    /// Whether this is the PE array (in either order).
    pub fn is_pipeline(self) -> bool {
        self.technique().is_none()
    }

    /// The golden technique this method runs, `None` for the PE array.
    pub fn technique(self) -> Option<Technique> {
        Some(match self {
            MethodArg::Reference => Technique::Reference,
            MethodArg::Er => Technique::Slice(Method::Er),
            MethodArg::ErFtb => Technique::Slice(Method::ErFtb),
            MethodArg::Under => Technique::Slice(Method::Under),
            MethodArg::Over => Technique::Slice(Method::Over),
            MethodArg::Box => Technique::Slice(Method::Box),
            MethodArg::Mipmap => Technique::MipMap,
            MethodArg::ShearWarp => Technique::ShearWarp,
            MethodArg::Pipeline | MethodArg::PipelineFtb => return None,
        })
    }

    /// The order the PE array runs in, `None` for a golden technique.
    pub fn pipeline_order(self) -> Option<Order> {
        match self {
            MethodArg::Pipeline => Some(Order::BackToFront),
            MethodArg::PipelineFtb => Some(Order::FrontToBack),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every method's name parses back to it, and the golden ones agree
    /// with the golden model's own names and parser.
    #[test]
    fn names_round_trip() {
        for m in MethodArg::value_variants() {
            let name = m.name();
            assert_eq!(MethodArg::parse(name), Some(*m), "{name}");
            let pv = m.to_possible_value().expect("visible");
            assert_eq!(pv.get_name(), name);
            match m.technique() {
                Some(t) => assert_eq!(name.parse::<Technique>().ok(), Some(t)),
                None => assert!(name.parse::<Technique>().is_err(), "{name}"),
            }
        }
        assert_eq!(MethodArg::parse("ER"), None);
    }
}
