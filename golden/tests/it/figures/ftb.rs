//! Front to back against back to front.

use super::*;

// ------------------------------------ 7. front-to-back against back-to-front

/// Zeroes the voxels of a +z view from slice `z0` on (view z = index z).
fn zero_behind(vol: &Volume, z0: usize) -> Volume {
    let [nx, ny, _] = vol.dims();
    let data = vol.data();
    volume(vol.dims(), |x, y, z| {
        if z >= z0 {
            0
        } else {
            data[(z * ny + y) * nx + x]
        }
    })
}

#[test]
fn front_to_back_without_termination_matches_back_to_front() {
    // Why the two differ. Let G be the front-to-back state of region 0's rays
    // at b_1 (accumulated opacity A), R the back-to-front colour of all that
    // lies behind b_1 on region 1's rays, S the split and M the merge. BTF
    // gives F0 + (1 - A) M(R); the FTB fold gives F0 + M((1 - S(A)) R). The
    // difference at ray m is sum_k W_k (A(m) - S(A)(2m + k)) R(2m + k) over the
    // 3x3 taps W_k: zero for k = 0 (the continued ray), |.| <= delta / 2 for
    // the four edge taps (weight 1/8 each: S averages two parents) and
    // <= 3 delta / 4 for the four corners (weight 1/16: four parents), where
    // delta is the largest difference of A between neighbouring region-0
    // rays (rays outside the grid count as A = 0) and R <= 1. So
    //     |FTB - BTF| <= 7/16 delta    (K = 2, baseplane and image: the warp
    //                                   is a normalised average),
    // and with K regions the terms of each boundary add up after merges that
    // are averages: <= 7/16 (delta_1 + ... + delta_{K-1}) <= 7/16 (K - 1).
    // For K = 2 delta is measurable: the FTB baseplane of the same view with
    // every slice from b_1 on made transparent is G itself (nothing is
    // added behind, so the fold returns region 0's states).
    let cases: Vec<(&str, Volume, TransferFunction)> = vec![
        (
            "sphere:32",
            scene("sphere:32"),
            tf_preset("sphere").unwrap(),
        ),
        ("ml:32", scene("ml:32"), tf_preset("ml").unwrap()),
        (
            "checker:32",
            scene("checker:32"),
            tf_preset("checker-mono").unwrap(),
        ),
        (
            "sparse random",
            sparse_random([32, 28, 24], 0.1, 11),
            tf_preset("grey-ramp").unwrap(),
        ),
        (
            "dense random",
            sparse_random([32, 28, 24], 0.6, 12),
            tf(&[(0.0, [0.0, 0.0, 0.0, 0.0]), (255.0, [1.0, 0.5, 0.2, 0.3])]),
        ),
    ];
    let off = opts(1.0, 1);
    let ro = RenderOptions {
        slice: off,
        ..RenderOptions::default()
    };
    for (name, vol, t) in &cases {
        let l = lut(t);
        let c = DVec3::from_array(vol.dims().map(|n| (n as f64 - 1.0) / 2.0));
        // Off-axis eyes in front (+z views, K = 2), so that zero_behind
        // applies, and one from behind (K = 3) for the general bound.
        for eye in [
            DVec3::new(40.0, 22.0, -20.0),
            DVec3::new(c.x - 6.3, c.y + 4.1, -17.0),
            DVec3::new(c.x + 3.3, c.y - 2.1, 2.0 * c.z + 8.0),
        ] {
            let cam = camera(eye, c, up_for(c - eye), 60.0, 48, 48);
            let p = prepare(vol, &cam);
            let er = render(&p, &l, Technique::Slice(Method::Er), &ro).unwrap();
            let ftb = render(&p, &l, Technique::Slice(Method::ErFtb), &ro).unwrap();
            let base = |f: &golden::render::Frame| f.slice.as_ref().unwrap().baseplane.data.clone();
            let d_base = max_diff_f32(&base(&er), &base(&ftb));
            let d_img = max_diff_f32(&er.image.data, &ftb.image.data);
            let regions = p.view.regions();
            let k = regions.count();
            let bound = if k == 2 && p.view.axes.label() == "+z" {
                let front = prepare(&zero_behind(vol, regions.slices(1).start), &cam);
                let g = slice_render(Method::ErFtb, &front, &l, &off).baseplane;
                let [w, h] = g.grid.counts;
                let a = |x: i64, y: i64| {
                    if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                        0.0
                    } else {
                        g.data[y as usize * w + x as usize][3]
                    }
                };
                let mut delta = 0f32;
                for y in -1..=h as i64 {
                    for x in -1..=w as i64 {
                        for (dx, dy) in [(1, 0), (0, 1), (1, 1), (1, -1)] {
                            delta = delta.max((a(x, y) - a(x + dx, y + dy)).abs());
                        }
                    }
                }
                7.0 / 16.0 * delta
            } else {
                7.0 / 16.0 * (k - 1) as f32
            };
            eprintln!(
                "{name} eye {eye} ({}, K {k}): |ftb - er| baseplane {d_base:.2e}, image {d_img:.2e}; \
                 bound {bound:.3}",
                p.view.axes.label()
            );
            assert!(
                d_base <= bound + 1e-5,
                "{name} eye {eye}: baseplane {d_base} > {bound}"
            );
            assert!(
                d_img <= bound + 1e-5,
                "{name} eye {eye}: image {d_img} > {bound}"
            );
            // Termination only drops what lies behind rays whose opacity has
            // reached the threshold: at most (1 - threshold) of each ray's
            // colour, and the fold and warp average rays with weights summing
            // to at most 1.
            for thr in [0.99f32, 0.9, 0.5] {
                let o = RenderOptions {
                    slice: opts(thr, 1),
                    ..RenderOptions::default()
                };
                let term = image(&p, &l, Technique::Slice(Method::ErFtb), &o);
                let d = max_diff_f32(&term.data, &ftb.image.data);
                assert!(
                    d <= 1.0 - thr + 1e-5,
                    "{name} eye {eye} threshold {thr}: {d}"
                );
            }
        }
    }
}

#[test]
fn front_to_back_differs_from_back_to_front_only_by_the_commutator() {
    // Where opacity is uniform the FTB - BTF difference above,
    //     E(m) = sum_k W_k (A(m) - S(A)(2m + k)) R(2m + k),
    // vanishes to first order and what is left is computable by hand. In a
    // full cube of constant value with colour c and opacity a per voxel, a
    // ray that stays inside samples every slice with the same path length
    // ds = sqrt(1 + slope_x^2 + slope_y^2) per slice, so (K = 2, n0 and n1
    // slices in regions 0 and 1):
    //     A(m) = 1 - (1 - a)^(n0 ds_m)        (region-0 ray m at b_1),
    //     R(n) = c (1 - (1 - a)^(n1 ds_n))    (region-1 ray n, BTF),
    // region-0 rays lie on the baseplane grid, region-1 rays on the grid
    // refined 2x (ray 2m continues ray m), and S averages the one, two or
    // four parents. E is then second order in the ray spacing: about
    // (R / 8) (1 - A) n0 ln(1 / (1 - a)) d^2(ds), with d^2(ds) ~ (1 / (2 D))^2
    // between neighbouring rays: 3e-5 to 1.2e-4 here, far below 1/255.
    // The test computes E by hand for every baseplane sample whose ray, and
    // every ray within two voxels of it, stays inside the cube to the last
    // slice (rays crossing a side face enter or leave at different depths
    // and see different opacities), and checks FTB - BTF against it.
    let n = 32usize;
    let (colour, a) = ([0.9f64, 0.6, 0.3], 0.08f32);
    let vol = volume([n; 3], |_, _, _| 150);
    let rgba = |alpha: f32| [colour[0], colour[1], colour[2], alpha as f64];
    let l = lut(&tf(&[(0.0, rgba(0.0)), (100.0, rgba(a)), (255.0, rgba(a))]));
    assert_eq!(l.lookup(150.0)[3], a);
    let c = (n as f64 - 1.0) / 2.0;
    let off = opts(1.0, 1);
    for eye in [
        DVec3::new(c, c, -20.0),
        DVec3::new(c + 3.7, c - 2.2, -12.5),
        DVec3::new(c - 1.3, c + 0.6, -28.0),
    ] {
        let cam = camera(eye, DVec3::splat(c), DVec3::Y, 60.0, 32, 32);
        let p = prepare(&vol, &cam);
        let regions = p.view.regions();
        assert_eq!(regions.count(), 2, "eye {eye}");
        let (n0, n1) = (
            regions.slices(0).len() as f64,
            regions.slices(1).len() as f64,
        );
        let er = slice_render(Method::Er, &p, &l, &off).baseplane;
        let ftb = slice_render(Method::ErFtb, &p, &l, &off).baseplane;
        let g = er.grid;
        let (d, e) = (p.view.d, p.view.eye);
        let ln = -(1.0 - a as f64).ln();
        let ds = |u: f64, v: f64| (1.0 + ((u - e.x) / d).powi(2) + ((v - e.y) / d).powi(2)).sqrt();
        let big_a = |u: f64, v: f64| 1.0 - (-ln * n0 * ds(u, v)).exp();
        let big_r = |u: f64, v: f64| 1.0 - (-ln * n1 * ds(u, v)).exp();
        let w1 = |k: i64| if k == 0 { 0.5 } else { 0.25 };
        let rear = (n as f64 - 1.0 + d) / d;
        let inside = |u: f64, a: usize| {
            let x = e[a] + (u - e[a]) * rear;
            let lim = |x: f64| (1.5..=n as f64 - 2.5).contains(&x);
            lim(x) && lim(u)
        };
        let s = g.spacing;
        let (mut worst, mut largest, mut count) = (0f64, 0f64, 0);
        for jy in 0..g.counts[1] {
            for jx in 0..g.counts[0] {
                let (u, v) = (g.origin[0] + jx as f64 * s, g.origin[1] + jy as f64 * s);
                if !(inside(u, 0) && inside(v, 1)) {
                    continue;
                }
                let am = big_a(u, v);
                let mut e_alpha = 0.0;
                for ky in -1..=1i64 {
                    for kx in -1..=1i64 {
                        // Parents of region-1 ray (2m + kx, 2m' + ky).
                        let px: &[f64] = if kx == 0 { &[0.0] } else { &[0.0, kx as f64] };
                        let py: &[f64] = if ky == 0 { &[0.0] } else { &[0.0, ky as f64] };
                        let mut split = 0.0;
                        for &oy in py {
                            for &ox in px {
                                split += big_a(u + ox * s, v + oy * s);
                            }
                        }
                        split /= (px.len() * py.len()) as f64;
                        let r = big_r(u + kx as f64 * s / 2.0, v + ky as f64 * s / 2.0);
                        e_alpha += w1(kx) * w1(ky) * (am - split) * r;
                    }
                }
                let i = jy * g.counts[0] + jx;
                for (ch, scale) in [colour[0], colour[1], colour[2], 1.0]
                    .into_iter()
                    .enumerate()
                {
                    let want = e_alpha * scale;
                    let got = ftb.data[i][ch] as f64 - er.data[i][ch] as f64;
                    worst = worst.max((got - want).abs());
                    largest = largest.max(want.abs());
                }
                count += 1;
            }
        }
        eprintln!(
            "uniform cube eye {eye}: {count} interior samples, |E| up to {largest:.2e}, \
             |(ftb - er) - E| up to {worst:.2e}"
        );
        assert!(count > 100, "enough interior samples");
        // A tenth of a grey level at most: far below 1/255.
        assert!(
            largest < 0.1 / 255.0,
            "eye {eye}: E {largest} should be second order"
        );
        assert!(worst < 2e-6, "eye {eye}: FTB - BTF is E to {worst}");
    }
}
