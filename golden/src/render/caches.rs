//! The caches of a [`Prepared`] view: each derived structure (occupancy,
//! mip-map, shear-warp stack, pre-integrated table) is built for the
//! last table and rebuilt only when the table's classification changes.

use std::sync::{Arc, Mutex};

use super::{KeyedPreTable, Prepared};
use crate::error::Result;
use crate::mipcast::MipOptions;
use crate::mipmap::{classification_key, Classify, MipMap};
use crate::occupancy::{table_key, Occupancy};
use crate::preint::{Colouring, PreTable};
use crate::shading::{GradientMode, Shade, Shader};
use crate::shearwarp::Classified;
use crate::tf::Lut;

/// Pre-integrated tables kept for the process, newest last: another
/// view of the same classification (another `Prepared`) reuses its
/// table, which for the exact colouring takes about a second to build.
const SHARED_PREINT: usize = 4;

/// The process's table for `key` (the classification's key and the
/// colouring), else `lut` pre-integrated and kept (the oldest of
/// [`SHARED_PREINT`] dropped).
fn shared_preint(key: (u64, Colouring), lut: &Lut, colouring: Colouring) -> Arc<PreTable> {
    static TABLES: Mutex<Vec<KeyedPreTable>> = Mutex::new(Vec::new());
    let lock = || {
        TABLES
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    };
    if let Some((_, t)) = lock().iter().find(|(k, _)| *k == key) {
        return Arc::clone(t);
    }
    // Built unlocked: frames of other classifications need not wait.
    let t = Arc::new(PreTable::with_colouring(lut, colouring));
    let mut tables = lock();
    tables.retain(|(k, _)| *k != key);
    if tables.len() >= SHARED_PREINT {
        tables.remove(0);
    }
    tables.push((key, Arc::clone(&t)));
    t
}

impl Prepared {
    /// The occupancy map of the blocks under `lut`: the map built for the
    /// last table when `lut` classifies like it (same opacities), else a
    /// new one, kept for the next frame.
    pub fn occupancy_for(&self, lut: &Lut) -> Arc<Occupancy> {
        let key = table_key(lut);
        // A poisoned lock only means another frame panicked mid-update;
        // the cache is then rebuilt.
        let mut cached = self
            .occupancy
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        match &*cached {
            Some((k, occ)) if *k == key => Arc::clone(occ),
            _ => {
                let occ = Arc::new(Occupancy::for_lut(&self.blocks, lut));
                *cached = Some((key, Arc::clone(&occ)));
                occ
            }
        }
    }
}

impl Prepared {
    /// The pre-integrated table of `lut` with `colouring`
    /// ([`crate::preint`]): the one built for the last table when `lut` has
    /// the same colours and opacities and the colouring is the same, else
    /// a new one, kept for the next frame.
    pub fn preint_for(&self, lut: &Lut, colouring: Colouring) -> Arc<PreTable> {
        let key = (classification_key(lut), colouring);
        let mut cached = self
            .preint
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        match &*cached {
            Some((k, t)) if *k == key => Arc::clone(t),
            _ => {
                let t = shared_preint(key, lut, colouring);
                *cached = Some((key, Arc::clone(&t)));
                t
            }
        }
    }

    /// The mip-map of the stack classified by `lut`: the one built for the
    /// last table when `lut` has the same colours and opacities, else a
    /// new one, kept for the next frame.
    pub fn mipmap_for(&self, lut: &Lut, classify: Classify) -> Result<Arc<MipMap>> {
        let key = match classify {
            Classify::Pre => classification_key(lut),
            Classify::Post => 0,
        };
        // As for the occupancy map, a poisoned lock only forces a rebuild.
        let mut cached = self
            .mipmap
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let slot = &mut cached[classify as usize];
        match slot {
            Some((k, m)) if *k == key => Ok(Arc::clone(m)),
            _ => {
                let m = Arc::new(MipMap::build(&self.stack, lut, classify)?);
                *slot = Some((key, Arc::clone(&m)));
                Ok(m)
            }
        }
    }
}

impl Prepared {
    /// The pyramid the mip-map caster reads with `mip`: shaded when
    /// pre-classified and shading ([`Prepared::mipmap_shaded_for`]), else
    /// [`Prepared::mipmap_for`].
    pub fn mipmap_of(&self, lut: &Lut, mip: &MipOptions) -> Result<Arc<MipMap>> {
        match (mip.classify, &mip.shade) {
            (Classify::Pre, Some(sh)) => self.mipmap_shaded_for(lut, sh),
            _ => self.mipmap_for(lut, mip.classify),
        }
    }

    /// The pre-classified pyramid shaded with `shade`
    /// ([`MipMap::build_shaded`]), cached in the pre-classified slot by the
    /// table's and the shading's keys, so that frames from one eye
    /// direction share it.
    pub fn mipmap_shaded_for(&self, lut: &Lut, shade: &Shade) -> Result<Arc<MipMap>> {
        let skey = crate::mipmap::shading_key(&self.view, shade);
        let key = {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            std::hash::Hash::hash(&(classification_key(lut), skey), &mut h);
            std::hash::Hasher::finish(&h)
        };
        let mut cached = self
            .mipmap
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let slot = &mut cached[Classify::Pre as usize];
        match slot {
            Some((k, m)) if *k == key && m.shading == Some(skey) => Ok(Arc::clone(m)),
            _ => {
                // The shader's lights and material only: the gradient is
                // each voxel's own.
                let mut sh = *shade;
                sh.gradient = GradientMode::Samples;
                let shader = Shader::with_gradients(&self.view, None, &sh)?;
                let grads = self.gradients();
                let m = Arc::new(MipMap::build_shaded(
                    &self.stack,
                    &grads,
                    lut,
                    &shader,
                    skey,
                )?);
                *slot = Some((key, Arc::clone(&m)));
                Ok(m)
            }
        }
    }

    /// The shear-warp classified stack under `lut` ([`Classified`]): the
    /// one built for the last table when `lut` has the same colours and
    /// opacities, else a new one, kept for the next frame.
    pub fn classified_for(&self, lut: &Lut) -> Result<Arc<Classified>> {
        let key = classification_key(lut);
        let mut cached = self
            .classified
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        match &*cached {
            Some((k, c)) if *k == key => Ok(Arc::clone(c)),
            _ => {
                let c = Arc::new(Classified::build(&self.stack, lut)?);
                *cached = Some((key, Arc::clone(&c)));
                Ok(c)
            }
        }
    }
}
