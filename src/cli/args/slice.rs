//! The renderers' options (`render` and `compare`): early termination,
//! substeps, pre-integration, skipping, clipping, the mip-map and
//! shear-warp settings, shading and the volume of interest, checked and
//! turned into golden's render options.

use anyhow::{bail, Result};
use clap::Args;

use golden::camera::Camera;
use golden::clip::ClipPlane;
use golden::render::{PrepareOptions, Prepared};
use golden::skip::Skips;
use golden::tf::TransferFunction;
use golden::volume::Volume;

use super::parse_vec3;

/// Options of the renderers, shared by `render` and `compare`.
#[derive(Debug, Clone, Args)]
#[command(next_help_heading = "Rendering")]
pub struct SliceArgs {
    /// Early ray termination opacity for er-ftb (1 disables it).
    #[arg(long, default_value_t = 0.99)]
    pub terminate: f32,
    /// Samples per slice crossing for slice-order methods (1 = the paper's one per slice).
    #[arg(long, default_value_t = golden::methods::DEFAULT_SUBSTEPS)]
    pub substeps: u32,
    /// Pre-integrated classification of each slice step from its front and
    /// back scalars (Engel et al. 2001), for the slice-order methods.
    #[arg(long)]
    pub preintegrate: bool,
    /// How a pre-integrated step weighs the colours along it: fast (the
    /// extinction-weighted mean, Engel's fast variant), attenuated
    /// (corrected to first order for attenuation within the step; golden
    /// only) or exact (the self-attenuated colour from a table with a
    /// step-depth axis; golden and the pipeline). Needs --preintegrate.
    #[arg(long, value_parser = parse_colouring, default_value = "fast")]
    pub pre_colouring: golden::preint::Colouring,
    /// Sample empty space too (skipping it never changes the image).
    #[arg(long)]
    pub no_skip_empty: bool,
    /// Sample rays that cannot reach the image and regions behind the
    /// volume too (culling never changes the image).
    #[arg(long)]
    pub no_cull: bool,
    /// Edge of the empty-space blocks in voxels (power of two, 2..64;
    /// default 4 in golden, the config's `occupancy_block` (16) in the
    /// pipeline).
    #[arg(long)]
    pub block: Option<usize>,
    /// Clip plane nx,ny,nz,d in world units: keeps n.p + d >= 0
    /// (repeat for up to 6 planes).
    #[arg(long, value_parser = parse_clip, allow_hyphen_values = true)]
    pub clip: Vec<ClipPlane>,
    /// Near plane: an eye on or inside the volume's slab sees only slices
    /// at least this many voxels in front of it.
    #[arg(long, default_value_t = golden::render::DEFAULT_NEAR)]
    pub near: f64,
    /// Mip-map sample step as a fraction of max(footprint, voxel)
    /// (1/16 to 4).
    #[arg(long, default_value_t = golden::mipcast::DEFAULT_MIP_STEP)]
    pub mip_step: f64,
    /// Mip-map classification: post (filter the scalar, classify each
    /// sample) or pre (filter classified colour and opacity, the paper's).
    #[arg(long, default_value = "post", value_parser = parse_classify)]
    pub mip_classify: golden::mipmap::Classify,
    /// Shear-warp intermediate image pixels per voxel of the front slice
    /// (1/8 to 8; 1 is Lacroute's 1:1).
    #[arg(long, default_value_t = golden::shearwarp::DEFAULT_SCALE)]
    pub intermediate_scale: f64,
    /// Shade samples with gradients and Blinn-Phong before compositing (a
    /// headlight unless --light is given; docs/golden.md#shading).
    #[arg(long, conflicts_with = "no_shade")]
    pub shade: bool,
    /// Emission-absorption only (the default).
    #[arg(long)]
    pub no_shade: bool,
    /// Directional light towards world direction dx,dy,dz (repeat for up
    /// to 4 lights; implies --shade).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub light: Vec<glam::DVec3>,
    /// Material ka,kd,ks,shininess (default VTK's 0.1,0.7,0.2,10; implies
    /// --shade).
    #[arg(long)]
    pub material: Option<String>,
    /// Opacity scaled by min(1, |gradient| / G), G in scalar units per
    /// world unit, so homogeneous regions go transparent (Levoy 1988;
    /// implies --shade).
    #[arg(long, allow_hyphen_values = true)]
    pub gradient_opacity: Option<f64>,
    /// Where gradients are taken: voxels (central differences on voxels,
    /// interpolated like the scalar; the default) or samples (differences
    /// of interpolated samples, Cube-4's); implies --shade.
    #[arg(long, value_parser = parse_gradient)]
    pub gradient: Option<golden::shading::GradientMode>,
    /// Gradient magnitude F (scalar units per world unit) over which a
    /// normal fades in: lighting uses min(1, |g|/F) of the normal and the
    /// rest as if facing the light (default 1; 0 disables; implies --shade;
    /// docs/golden.md#shading).
    #[arg(long, allow_hyphen_values = true)]
    pub normal_fade: Option<f64>,
    /// Volume of interest in world units: box:x0,y0,z0,x1,y1,z1 or
    /// sphere:cx,cy,cz,r; opacity inside it is scaled by --voi-scale.
    #[arg(long, value_parser = parse_voi, allow_hyphen_values = true)]
    pub voi: Option<golden::voi::Shape>,
    /// Opacity factor of the volume of interest (0..=100).
    #[arg(long, default_value_t = 2.0, allow_hyphen_values = true)]
    pub voi_scale: f64,
    /// Scale opacity outside the volume of interest instead of inside.
    #[arg(long)]
    pub voi_outside: bool,
    /// Width in world units of the transition at the region's boundary.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub voi_ramp: f64,
}

pub(crate) fn parse_voi(s: &str) -> std::result::Result<golden::voi::Shape, String> {
    s.parse().map_err(|e: golden::Error| e.to_string())
}

fn parse_colouring(s: &str) -> std::result::Result<golden::preint::Colouring, String> {
    s.parse().map_err(|e: golden::Error| e.to_string())
}

fn parse_gradient(s: &str) -> std::result::Result<golden::shading::GradientMode, String> {
    s.parse().map_err(|e: golden::Error| e.to_string())
}

fn parse_classify(s: &str) -> std::result::Result<golden::mipmap::Classify, String> {
    s.parse().map_err(|e: golden::Error| e.to_string())
}

fn parse_clip(s: &str) -> std::result::Result<ClipPlane, String> {
    s.parse().map_err(|e: golden::Error| e.to_string())
}

impl SliceArgs {
    /// Checks and builds the render options.
    pub fn options(&self) -> Result<golden::render::RenderOptions> {
        let mut o = golden::render::RenderOptions::default();
        o.slice.terminate = self.terminate;
        o.slice.substeps = self.substeps;
        o.slice.preintegrate = self.preintegrate;
        o.slice.pre_colouring = self.pre_colouring;
        o.slice.skips = Skips {
            empty: !self.no_skip_empty,
            cull: !self.no_cull,
        };
        o.slice.shade = self.shading()?;
        o.reference.shade = o.slice.shade;
        o.slice.voi = self.voi.map(|shape| golden::voi::Voi {
            shape,
            scale: self.voi_scale,
            outside: self.voi_outside,
            ramp: self.voi_ramp,
        });
        o.reference.voi = o.slice.voi;
        o.slice.validate()?;
        golden::mipcast::check_step(self.mip_step)?;
        o.mip_step = self.mip_step;
        o.mip_classify = self.mip_classify;
        golden::shearwarp::check_scale(self.intermediate_scale)?;
        o.sw_scale = self.intermediate_scale;
        Ok(o)
    }

    /// The shading asked for: `--shade`, or any of `--light`,
    /// `--material`, `--gradient-opacity`; `None` with `--no-shade`.
    pub fn shading(&self) -> Result<Option<golden::shading::Shade>> {
        let asked = self.shade
            || !self.light.is_empty()
            || self.material.is_some()
            || self.gradient_opacity.is_some()
            || self.gradient.is_some()
            || self.normal_fade.is_some();
        if self.no_shade {
            if asked {
                bail!(
                    "--no-shade conflicts with --shade, --light, --material and --gradient-opacity"
                );
            }
            return Ok(None);
        }
        if !asked {
            return Ok(None);
        }
        let mut sh = golden::shading::Shade::default();
        for &l in &self.light {
            sh.add_light(l)?;
        }
        if let Some(m) = &self.material {
            sh.material = golden::shading::Material::parse(m)?;
        }
        if let Some(g) = self.gradient_opacity {
            sh.gradient_opacity = g;
        }
        if let Some(g) = self.gradient {
            sh.gradient = g;
        }
        if let Some(f) = self.normal_fade {
            sh.normal_fade = f;
        }
        sh.validate()?;
        Ok(Some(sh))
    }

    /// Completes `o` with what the transfer function asks for: a table
    /// with a `[material]` is rendered shaded with it (unless
    /// `--no-shade`; `--material` overrides it).
    pub fn apply_tf(
        &self,
        o: &mut golden::render::RenderOptions,
        tf: &TransferFunction,
    ) -> Result<()> {
        let Some(m) = tf.material else { return Ok(()) };
        if self.no_shade {
            return Ok(());
        }
        let mut sh = o.slice.shade.unwrap_or_default();
        if self.material.is_none() {
            sh.material = m;
        }
        o.slice.shade = Some(sh);
        o.reference.shade = Some(sh);
        Ok(())
    }

    /// Checks and builds how the volume is prepared for a camera.
    pub fn prepare(&self) -> Result<PrepareOptions> {
        let block = self.block.unwrap_or(golden::occupancy::DEFAULT_BLOCK);
        golden::occupancy::check_block(block)?;
        golden::clip::check_planes(&self.clip)?;
        if !(self.near.is_finite() && self.near > 0.0) {
            bail!("--near {} must be a positive number of voxels", self.near);
        }
        Ok(PrepareOptions {
            block,
            clip: self.clip.clone(),
            near: self.near,
        })
    }

    /// Prepares `vol` for `cam` with these options.
    pub fn prepared(&self, vol: &Volume, cam: &Camera) -> Result<Prepared> {
        Ok(Prepared::with(vol, cam, &self.prepare()?)?)
    }

    /// [`SliceArgs::prepared`], taking `vol` (its voxels become the slice
    /// stack: a one-off frame holds them once).
    pub fn prepared_owning(&self, vol: Volume, cam: &Camera) -> Result<Prepared> {
        Ok(Prepared::owning(vol, cam, &self.prepare()?)?)
    }
}

impl Default for SliceArgs {
    fn default() -> SliceArgs {
        let o = golden::methods::Options::default();
        let p = PrepareOptions::default();
        SliceArgs {
            terminate: o.terminate,
            substeps: o.substeps,
            preintegrate: o.preintegrate,
            pre_colouring: o.pre_colouring,
            no_skip_empty: !o.skips.empty,
            no_cull: !o.skips.cull,
            block: None,
            clip: p.clip,
            near: p.near,
            mip_step: golden::mipcast::DEFAULT_MIP_STEP,
            mip_classify: golden::mipmap::Classify::Post,
            intermediate_scale: golden::shearwarp::DEFAULT_SCALE,
            shade: false,
            no_shade: false,
            light: Vec::new(),
            material: None,
            gradient_opacity: None,
            normal_fade: None,
            gradient: None,
            voi: None,
            voi_scale: 2.0,
            voi_outside: false,
            voi_ramp: 0.0,
        }
    }
}
