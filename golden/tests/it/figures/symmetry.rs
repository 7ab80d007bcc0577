//! The six sides of a symmetric object, and determinism across thread
//! counts.

use super::*;

// ------------------------------------ 8. six sides of a symmetric object

#[test]
fn six_sides_of_a_chirally_symmetric_object_give_one_image() {
    // A 33^3 volume, centre c = 16, holding 24 soft blobs at c + R (3, 7, 11)
    // for the 24 rotations R of the cube (signed permutations of determinant
    // +1). It is invariant under every rotation of the cube about c (which
    // maps the voxel lattice to itself) but not under a mirror: it is
    // chiral, so a handedness error in any view shows.
    //
    // A camera on axis +-k at distance d from c, looking at c with up along
    // another axis, has a basis (f, r = f x up, u) of signed axes. For two such
    // cameras the rotation R taking f1 -> f2, up1 -> up2 is proper and maps
    // r1 -> r2 (r = f x up is preserved by proper rotations), so it maps
    // pixel (i, j)'s ray of camera 1 onto pixel (i, j)'s ray of camera 2 and
    // the volume onto itself: all images are equal pixel for pixel, with no
    // flip. The same holds for ER's ray sets: with the eye on the centre
    // line every view places the rear rays on the voxel lattice, and a mirror
    // of view x or y about c maps ray m to ray (n - 1) / 2^(K-1-i) - m in
    // region i, which keeps the merge parity when 2^(K-1) divides n - 1 = 32
    // (K = 3 here).
    //
    // Within one image, rotating the camera by +90 degrees about f is such an
    // R, so img(i, j) = img(j, W - 1 - i); a mirror is not, and must differ.
    let n = 33usize;
    let c = 16i64;
    let mut centres = Vec::new();
    let base = [3i64, 7, 11];
    for perm in [
        [0, 1, 2],
        [1, 2, 0],
        [2, 0, 1],
        [0, 2, 1],
        [2, 1, 0],
        [1, 0, 2],
    ] {
        let even = perm == [0, 1, 2] || perm == [1, 2, 0] || perm == [2, 0, 1];
        for signs in 0..8 {
            let s = [
                1 - 2 * (signs & 1),
                1 - 2 * ((signs >> 1) & 1),
                1 - 2 * ((signs >> 2) & 1),
            ];
            let negative = s.iter().filter(|&&v| v < 0).count() % 2 == 1;
            if even != negative {
                centres.push([0, 1, 2].map(|k| c + s[k] * base[perm[k]]));
            }
        }
    }
    assert_eq!(centres.len(), 24);
    let vol = volume([n; 3], |x, y, z| {
        let p = [x as i64, y as i64, z as i64];
        let best = centres
            .iter()
            .map(|q| ((0..3).map(|k| (p[k] - q[k]).pow(2)).sum::<i64>() as f64).sqrt())
            .fold(f64::INFINITY, f64::min);
        (255.0 * (1.0 - best / 3.0).max(0.0)).round() as u16
    });
    let l = lut(&tf(&[
        (0.0, [0.0, 0.0, 1.0, 0.0]),
        (128.0, [0.0, 1.0, 0.0, 0.3]),
        (255.0, [1.0, 0.0, 0.0, 0.8]),
    ]));
    let centre = DVec3::splat(c as f64);
    let dist = 16.0 + 5.0; // D = 5: bounds 0, 5, 15, 35, K = 3
    let size = 48u32;
    let ro = RenderOptions::default();
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    for tech in [Technique::Slice(Method::Er), Technique::Reference] {
        let mut first: Option<Image> = None;
        for k in 0..3 {
            for sign in [1.0, -1.0] {
                for up in [axes[(k + 1) % 3], -axes[(k + 2) % 3]] {
                    let eye = centre - sign * dist * axes[k];
                    let cam = camera(eye, centre, up, 90.0, size, size);
                    let p = prepare(&vol, &cam);
                    assert_eq!(p.view.regions().count(), 3);
                    let img = image(&p, &l, tech, &ro);
                    let w = size as usize;
                    let px = |im: &Image, i: usize, j: usize| im.get(i, j);
                    let (mut rot, mut mirror) = (0f32, 0f32);
                    for j in 0..w {
                        for i in 0..w {
                            let a = px(&img, i, j);
                            let (b, m) = (px(&img, j, w - 1 - i), px(&img, w - 1 - i, j));
                            for ch in 0..4 {
                                rot = rot.max((a[ch] - b[ch]).abs());
                                mirror = mirror.max((a[ch] - m[ch]).abs());
                            }
                        }
                    }
                    let label = format!("{} eye {eye} up {up}", tech.name());
                    assert!(rot < 1e-5, "{label}: 90 degree rotation differs by {rot}");
                    assert!(
                        mirror > 0.05,
                        "{label}: the mirror image should differ ({mirror})"
                    );
                    match &first {
                        None => first = Some(img),
                        Some(f) => {
                            let d = max_diff_f32(&f.data, &img.data);
                            eprintln!("{label}: vs the first side {d:.2e}, mirror {mirror:.3}");
                            assert!(d < 1e-5, "{label}: differs from the first side by {d}");
                        }
                    }
                }
            }
        }
    }
}

// ------------------------------------ 9. determinism across thread counts

#[test]
fn images_and_stats_are_identical_with_1_2_and_3_threads() {
    let vol = sparse_random([24, 20, 28], 0.3, 5);
    let l = lut(&tf(&[
        (0.0, [0.0, 0.0, 0.0, 0.0]),
        (255.0, [1.0, 0.6, 0.3, 0.4]),
    ]));
    let c = DVec3::new(11.5, 9.5, 13.5);
    let eye = DVec3::new(30.0, -7.0, -15.0);
    let cam = camera(eye, c, DVec3::Y, 70.0, 40, 36);
    let p = prepare(&vol, &cam);
    let o = RenderOptions {
        slice: opts(0.9, 2),
        ..RenderOptions::default()
    };
    let techs = [
        Technique::Slice(Method::Er),
        Technique::Slice(Method::ErFtb),
        Technique::Slice(Method::Box),
        Technique::Slice(Method::Over),
        Technique::Slice(Method::Under),
        Technique::Reference,
    ];
    type Run = Vec<(Vec<u32>, Option<methods::Stats>)>;
    let run = |threads: usize| -> Run {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                techs
                    .iter()
                    .map(|&t| {
                        let f = render(&p, &l, t, &o).unwrap();
                        let bits = f.image.data.iter().flatten().map(|v| v.to_bits()).collect();
                        (bits, f.slice.map(|s| s.stats))
                    })
                    .collect()
            })
    };
    let one = run(1);
    assert!(one[0].0.iter().any(|&b| b != 0), "the view shows something");
    for threads in [2, 3] {
        let other = run(threads);
        for ((t, a), b) in techs.iter().zip(&one).zip(&other) {
            assert!(
                a.0 == b.0,
                "{} image differs with {threads} threads",
                t.name()
            );
            assert_eq!(a.1, b.1, "{} stats differ with {threads} threads", t.name());
        }
    }
}
