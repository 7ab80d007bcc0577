//! The geometry and rescale of each frame of a DICOM object: a
//! single-frame slice's from its top-level attributes; an enhanced
//! multi-frame object's (Enhanced CT/MR, ...) from its functional groups,
//! the frame's own (`PerFrameFunctionalGroupsSequence`) before the shared
//! ones (`SharedFunctionalGroupsSequence`) before the top level; a plain
//! multi-frame object's from the top level, its frames stepping along the
//! slice normal by `SpacingBetweenSlices` (else `SliceThickness`).

use dicom_dictionary_std::tags;
use dicom_object::mem::{InMemDicomObject, InMemElement};
use dicom_object::Tag;

/// What places one frame and turns its stored values into real ones.
#[derive(Debug, Clone)]
pub(super) struct Geometry {
    pub orient: [[f64; 3]; 2],
    pub position: [f64; 3],
    /// Between columns (x) and between rows (y), mm.
    pub pixel_spacing: [f64; 2],
    pub slope: f64,
    pub intercept: f64,
    pub thickness: Option<f64>,
}

/// Where an attribute of one frame is looked up, first match wins.
struct Groups<'a> {
    per_frame: Option<&'a InMemDicomObject>,
    shared: Option<&'a InMemDicomObject>,
    top: &'a InMemDicomObject,
}

/// An element, if present and readable.
pub(super) fn elem(obj: &InMemDicomObject, tag: Tag) -> Option<&InMemElement> {
    obj.element_opt(tag).ok().flatten()
}

/// The first item of sequence `seq`.
fn first_item(obj: &InMemDicomObject, seq: Tag) -> Option<&InMemDicomObject> {
    elem(obj, seq)
        .and_then(|e| e.items())
        .and_then(|i| i.first())
}

impl Groups<'_> {
    /// `tag` in the functional group macro `seq` of this frame, of the
    /// shared groups, else at the top level.
    fn get(&self, seq: Tag, tag: Tag) -> Option<&InMemElement> {
        [self.per_frame, self.shared]
            .into_iter()
            .flatten()
            .find_map(|g| first_item(g, seq).and_then(|i| elem(i, tag)))
            .or_else(|| elem(self.top, tag))
    }

    fn floats(&self, seq: Tag, tag: Tag, name: &str, n: usize) -> Result<Vec<f64>, String> {
        let v = self
            .get(seq, tag)
            .and_then(|e| e.to_multi_float64().ok())
            .ok_or_else(|| format!("{name} is missing or not numbers"))?;
        if v.len() != n || v.iter().any(|c| !c.is_finite()) {
            return Err(format!("{name} {v:?} is not {n} finite numbers"));
        }
        Ok(v)
    }

    fn opt_float(&self, seq: Tag, tag: Tag) -> Option<f64> {
        self.get(seq, tag)
            .and_then(|e| e.to_float64().ok())
            .filter(|v| v.is_finite())
    }

    /// An optional number that, when present, must be finite (and positive
    /// if `positive`): a `nan` slope or spacing is refused, not ignored.
    fn checked_float(
        &self,
        seq: Tag,
        tag: Tag,
        name: &str,
        positive: bool,
    ) -> Result<Option<f64>, String> {
        let Some(e) = self.get(seq, tag) else {
            return Ok(None);
        };
        if e.value()
            .primitive()
            .is_some_and(|p| p.to_str().trim_matches(['\0', ' ']).is_empty())
        {
            return Ok(None);
        }
        match e.to_float64() {
            Ok(v) if v.is_finite() && (!positive || v > 0.0) => Ok(Some(v)),
            Ok(v) => Err(format!(
                "{name} {v} must be a finite{} number",
                if positive { ", positive" } else { "" }
            )),
            Err(_) => Err(format!("{name} is not a number")),
        }
    }
}

/// The geometry of each of the object's `frames` frames, or why it has
/// none (a message naming the frame when there are several).
pub(super) fn frame_geometry(
    obj: &InMemDicomObject,
    frames: usize,
) -> Result<Vec<Geometry>, String> {
    let shared = first_item(obj, tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE);
    let per_frame = match elem(obj, tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE) {
        None => None,
        Some(e) => {
            let items = e
                .items()
                .ok_or("PerFrameFunctionalGroupsSequence is not a sequence")?;
            if items.len() != frames {
                return Err(format!(
                    "PerFrameFunctionalGroupsSequence has {} items, NumberOfFrames is {frames}",
                    items.len()
                ));
            }
            Some(items)
        }
    };
    let mut out = Vec::with_capacity(frames);
    for k in 0..frames {
        let g = Groups {
            per_frame: per_frame.map(|items| &items[k]),
            shared,
            top: obj,
        };
        let at = |e: String| {
            if frames > 1 {
                format!("frame {}: {e}", k + 1)
            } else {
                e
            }
        };
        out.push(geometry(&g).map_err(at)?);
    }
    let positioned = per_frame.is_some_and(|items| {
        items
            .iter()
            .all(|i| first_item(i, tags::PLANE_POSITION_SEQUENCE).is_some())
    });
    if frames > 1 && !positioned {
        step_along_normal(&mut out, shared, obj)?;
    }
    Ok(out)
}

/// A plain multi-frame object's frames (one position for all): frame `k`
/// at `k` steps of `SpacingBetweenSlices` (else `SliceThickness`) along
/// the slice normal from the given position.
fn step_along_normal(
    out: &mut [Geometry],
    shared: Option<&InMemDicomObject>,
    top: &InMemDicomObject,
) -> Result<(), String> {
    let g = Groups {
        per_frame: None,
        shared,
        top,
    };
    let step = g
        .checked_float(
            tags::PIXEL_MEASURES_SEQUENCE,
            tags::SPACING_BETWEEN_SLICES,
            "SpacingBetweenSlices",
            true,
        )?
        .or(out[0].thickness)
        .filter(|&s| s > 0.0)
        .ok_or(
            "the frames have no positions (PlanePositionSequence) and no positive \
             SpacingBetweenSlices or SliceThickness to step by",
        )?;
    let [r, c] = out[0].orient;
    let n = super::cross(r, c);
    let p0 = out[0].position;
    for (k, f) in out.iter_mut().enumerate() {
        f.position = std::array::from_fn(|i| p0[i] + k as f64 * step * n[i]);
    }
    Ok(())
}

fn geometry(g: &Groups) -> Result<Geometry, String> {
    let iop = g.floats(
        tags::PLANE_ORIENTATION_SEQUENCE,
        tags::IMAGE_ORIENTATION_PATIENT,
        "ImageOrientationPatient",
        6,
    )?;
    let ipp = g.floats(
        tags::PLANE_POSITION_SEQUENCE,
        tags::IMAGE_POSITION_PATIENT,
        "ImagePositionPatient",
        3,
    )?;
    let ps = g.floats(
        tags::PIXEL_MEASURES_SEQUENCE,
        tags::PIXEL_SPACING,
        "PixelSpacing",
        2,
    )?;
    if ps.iter().any(|&s| s <= 0.0) {
        return Err(format!("PixelSpacing {ps:?} must be positive"));
    }
    let orient = super::orientation(&iop).ok_or_else(|| {
        format!("ImageOrientationPatient {iop:?} is not two orthogonal directions")
    })?;
    let pvt = tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE;
    let slope = g
        .checked_float(pvt, tags::RESCALE_SLOPE, "RescaleSlope", false)?
        .unwrap_or(1.0);
    let intercept = g
        .checked_float(pvt, tags::RESCALE_INTERCEPT, "RescaleIntercept", false)?
        .unwrap_or(0.0);
    if slope == 0.0 {
        return Err("RescaleSlope is 0".into());
    }
    Ok(Geometry {
        orient,
        position: [ipp[0], ipp[1], ipp[2]],
        // PixelSpacing is (between rows, between columns).
        pixel_spacing: [ps[1], ps[0]],
        slope,
        intercept,
        thickness: g
            .opt_float(tags::PIXEL_MEASURES_SEQUENCE, tags::SLICE_THICKNESS)
            .filter(|&t| t > 0.0),
    })
}
