//! The renderer's non-diffuse materials (`docs/scene-format.md`,
//! "Transparency, mirrors, refraction"): mirrors with a tint, refraction by
//! Snell's law with Fresnel weights, semi-transparent fragments composited
//! front to back (writing no depth), the bounded ray depth, the layers a v2
//! trace stores, the non-diffuse mask, and the material errors.

use glam::DVec3;
use postwarp::scene::Scene;
use postwarp::trace::layers::{Node, SpecularMaterial, fresnel};
use postwarp_rtl::{Camera, Intrinsics, Pose};

const SPLINE: &str = r#"
[spline]
duration_s = 4.0
[[spline.waypoints]]
position = [0.0, 1.6, 4.0]
look_at = [0.0, 1.0, 0.0]
[[spline.waypoints]]
position = [1.0, 1.6, 4.0]
look_at = [0.0, 1.0, 0.0]
"#;

/// Full ambient light: every diffuse surface shows its albedo exactly.
const FLAT_LIGHT: &str = "[light]\nambient = 1.0\n";

fn scene(body: &str) -> Scene {
    // A top-level `ray_depth` line must come before any table.
    let body = body.trim_start();
    let (top, rest) = match body.strip_prefix("ray_depth") {
        Some(r) => {
            let (value, rest) = r.split_once('\n').unwrap();
            (format!("ray_depth{value}\n"), rest)
        }
        None => (String::new(), body),
    };
    Scene::from_toml_str(&format!("{top}{FLAT_LIGHT}{rest}\n{SPLINE}"), None, "inline.toml")
        .unwrap_or_else(|e| panic!("{e}"))
}

fn scene_err(body: &str) -> String {
    match Scene::from_toml_str(&format!("{body}\n{SPLINE}"), None, "inline.toml") {
        Ok(_) => panic!("expected an error for:\n{body}"),
        Err(e) => e.to_string(),
    }
}

fn camera(w: u32, h: u32, pos: DVec3, target: DVec3) -> Camera {
    Camera { intrinsics: Intrinsics::from_hfov(w, h, 40.0), pose: Pose::look_at(pos, target, DVec3::Y) }
}

fn close(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

/// A wall of `colour` at z = 5 (facing the camera at the origin), optional
/// extra objects and materials.
fn wall_and(colour: &str, extra: &str) -> String {
    format!(
        r#"
[materials.wall]
colour = {colour}
[[objects]]
kind = "plane"
material = "wall"
centre = [0.0, 0.0, 5.0]
half_u = [20.0, 0.0, 0.0]
half_v = [0.0, 20.0, 0.0]
{extra}"#
    )
}

#[test]
fn a_tinted_mirror_shows_the_scene_behind_the_camera() {
    // Mirror at z = 5 facing the camera; a wall at z = -5 behind it.
    let s = scene(
        r#"
[materials.mirror]
colour = [0.0, 0.0, 0.0]
reflect = [0.5, 1.0, 0.25]
[materials.back]
colour = [0.8, 0.6, 0.4]
[[objects]]
kind = "plane"
material = "mirror"
centre = [0.0, 0.0, 5.0]
half_u = [20.0, 0.0, 0.0]
half_v = [0.0, 20.0, 0.0]
[[objects]]
kind = "plane"
material = "back"
centre = [0.0, 0.0, -5.0]
half_u = [20.0, 0.0, 0.0]
half_v = [0.0, 20.0, 0.0]
"#,
    );
    let cam = camera(9, 7, DVec3::ZERO, DVec3::new(0.0, 0.0, 5.0));
    let r = s.render_layers(&cam, 1, 4);
    let i = 3 * 9 + 4; // centre sample
    assert!(close(r.samples.colour[i], [0.4, 0.6, 0.1], 1e-6), "{:?}", r.samples.colour[i]);
    assert_eq!(r.samples.z[i], 5.0, "depth is the mirror's");
    assert_eq!(r.samples.object_id[i], 1);
    assert!(r.nondiffuse.all());
    assert!(r.fragments.is_none(), "no semi-transparent material");
    let rt = r.raytree.unwrap();
    assert_eq!(rt.materials, vec![SpecularMaterial::Mirror]);
    assert!(rt.has(i, Node::Diffuse) && rt.has(i, Node::Reflect) && !rt.has(i, Node::Refract));
    assert_eq!(rt.material[i], 1);
    assert!((rt.nodes[Node::Reflect as usize].depth[i] - 10.0).abs() < 1e-4, "mirror to the back wall");
    assert!(close(rt.nodes[Node::Reflect as usize].colour[i], [0.4, 0.6, 0.1], 1e-6), "tint in, Fresnel out");
    assert_eq!(rt.nodes[Node::Diffuse as usize].colour[i], [0.0; 3]);
    assert_eq!(rt.nodes[Node::Diffuse as usize].depth[i], 5.0);
}

#[test]
fn refraction_follows_snell_and_weighs_by_fresnel() {
    // A pool: a refracting plane at y = 0 over a floor at y = -1, seen at 45°.
    let s = scene(
        r#"
[materials.water]
colour = [0.0, 0.0, 0.0]
refract = [1.0, 1.0, 1.0]
ior = 1.5
[materials.floor]
colour = [0.5, 0.5, 0.5]
[materials.sky]
colour = [1.0, 1.0, 1.0]
[[objects]]
kind = "plane"
material = "water"
centre = [0.0, 0.0, 0.0]
half_u = [0.0, 0.0, 50.0]
half_v = [50.0, 0.0, 0.0]
[[objects]]
kind = "plane"
material = "floor"
centre = [0.0, -1.0, 0.0]
half_u = [0.0, 0.0, 50.0]
half_v = [50.0, 0.0, 0.0]
[[objects]]
kind = "sphere"
material = "sky"
centre = [0.0, 0.0, 0.0]
radius = 40.0
"#,
    );
    let cam = camera(9, 7, DVec3::new(0.0, 2.0, -2.0), DVec3::ZERO);
    let r = s.render_layers(&cam, 1, 4);
    let i = 3 * 9 + 4;
    let rt = r.raytree.unwrap();
    assert!(rt.has(i, Node::Refract) && rt.has(i, Node::Reflect), "a dielectric has both");
    let sin_t = (45f64.to_radians().sin() / 1.5).min(1.0);
    let want = 1.0 / (1.0 - sin_t * sin_t).sqrt(); // from the surface down to the floor
    let got = rt.nodes[Node::Refract as usize].depth[i] as f64;
    assert!((got - want).abs() < 1e-4, "refracted path {got} vs Snell {want}");
    // Colour = F·sky + (1 − F)·floor (the reflected ray meets the sky sphere).
    let v = DVec3::new(0.0, -1.0, 1.0).normalize();
    let f = fresnel(v, DVec3::Y, 1.5) as f32;
    let want_c = f * 1.0 + (1.0 - f) * 0.5;
    assert!(close(r.samples.colour[i], [want_c; 3], 1e-5), "{:?} vs {want_c} (F = {f})", r.samples.colour[i]);
    assert_eq!(rt.materials, vec![SpecularMaterial::Dielectric { ior: 1.5 }]);
}

#[test]
fn semi_transparent_fragments_composite_and_write_no_depth() {
    let pane = |opacity: f64| {
        wall_and(
            "[0.2, 0.4, 0.8]",
            &format!(
                r#"
[materials.glass]
colour = [1.0, 0.5, 0.0]
opacity = {opacity}
[[objects]]
kind = "plane"
material = "glass"
centre = [0.0, 0.0, 2.0]
half_u = [20.0, 0.0, 0.0]
half_v = [0.0, 20.0, 0.0]
"#
            ),
        )
    };
    let cam = camera(5, 5, DVec3::ZERO, DVec3::new(0.0, 0.0, 5.0));
    let bare = scene(&wall_and("[0.2, 0.4, 0.8]", "")).render(&cam, 1);
    let clear = scene(&pane(0.0)).render_layers(&cam, 1, 4);
    assert_eq!(clear.samples.colour, bare.colour, "a fully transparent pane changes no colour");
    assert_eq!(clear.samples.z, bare.z, "nor the depth");
    let f = clear.fragments.as_ref().unwrap();
    assert!(f.count.iter().all(|&c| c == 1) && f.at(0)[0].alpha == 0.0 && f.at(0)[0].z == 2.0);
    assert!(clear.nondiffuse.all(), "but the ray did meet a fragment");
    let half = scene(&pane(0.5)).render_layers(&cam, 1, 4);
    assert!(close(half.samples.colour[12], [0.6, 0.45, 0.4], 1e-6), "{:?}", half.samples.colour[12]);
    assert_eq!(half.samples.z, bare.z, "semi-transparent surfaces write no depth");
    let f = half.fragments.unwrap();
    assert_eq!(f.opaque[12], [0.2, 0.4, 0.8], "the opaque surface behind, as a G-buffer holds it");
    assert_eq!(f.at(12)[0].colour, [1.0, 0.5, 0.0]);
    // Two panes, the layer keeps one: the colour still composites both.
    let two = format!(
        "{}\n[[objects]]\nkind = \"plane\"\nmaterial = \"glass\"\ncentre = [0.0, 0.0, 3.0]\nhalf_u = [20.0, 0.0, 0.0]\nhalf_v = [0.0, 20.0, 0.0]\n",
        pane(0.5)
    );
    let r = scene(&two).render_layers(&cam, 1, 1);
    let f = r.fragments.unwrap();
    assert!(f.count.iter().all(|&c| c == 1) && f.at(12)[0].z == 2.0, "nearest first, cut at max");
    let want = [0.5 + 0.25 * 1.0 + 0.25 * 0.2, 0.25 + 0.125 + 0.25 * 0.4, 0.0 + 0.0 + 0.25 * 0.8];
    assert!(close(r.samples.colour[12], want, 1e-6), "{:?}", r.samples.colour[12]);
}

#[test]
fn ray_depth_bounds_the_bounces_between_two_mirrors() {
    let body = |depth: u32| {
        format!(
            r#"
ray_depth = {depth}
[materials.mirror]
colour = [0.1, 0.1, 0.1]
reflect = [0.5, 0.5, 0.5]
[[objects]]
kind = "plane"
material = "mirror"
centre = [0.0, 0.0, 5.0]
half_u = [20.0, 0.0, 0.0]
half_v = [0.0, 20.0, 0.0]
[[objects]]
kind = "plane"
material = "mirror"
centre = [0.0, 0.0, -5.0]
half_u = [20.0, 0.0, 0.0]
half_v = [0.0, 20.0, 0.0]
"#
        )
    };
    let cam = camera(3, 3, DVec3::ZERO, DVec3::new(0.0, 0.0, 5.0));
    // Each bounce adds 0.1·0.5^k: depth d gives 0.1·(1 − 0.5^(d+1))/(1 − 0.5).
    for d in [1u32, 2, 4, 16] {
        let c = scene(&body(d)).render(&cam, 1).colour[4][0];
        let want = 0.1 * (1.0 - 0.5f32.powi(d as i32 + 1)) / 0.5;
        assert!((c - want).abs() < 1e-5, "ray_depth {d}: {c} vs {want}");
    }
}

#[test]
fn scaling_the_non_diffuse_objects_changes_their_share_only() {
    let s = Scene::builtin("gallery").unwrap();
    assert_eq!(s.nondiffuse_count(), 8, "mirror, sphere, slab and five windows");
    let path = s.spline.waypoints[0].clone();
    let cam = Camera {
        intrinsics: Intrinsics::from_hfov(64, 48, 60.0),
        pose: Pose::look_at(path.position, path.look_at, DVec3::Y),
    };
    let share = |sc: &Scene| {
        let m = sc.render_layers(&cam, 1, 4).nondiffuse;
        m.count_ones() as f64 / m.len() as f64
    };
    let (small, one, big) = (share(&s.with_nondiffuse_scaled(0.5)), share(&s), share(&s.with_nondiffuse_scaled(1.5)));
    assert!(small < one && one < big, "{small} {one} {big}");
    assert_eq!(s.with_nondiffuse_scaled(1.0).render(&cam, 1), s.render(&cam, 1));
}

#[test]
fn material_errors_say_what_was_expected() {
    let m = |keys: &str| {
        format!(
            "[materials.m]\ncolour = [0.5, 0.5, 0.5]\n{keys}\n[[objects]]\nkind = \"sphere\"\nmaterial = \"m\"\ncentre = [0.0, 0.0, 0.0]\nradius = 1.0\n"
        )
    };
    let e = scene_err(&m("refract = [1.0, 1.0, 1.0]"));
    assert!(e.contains("material `m`") && e.contains("`refract` needs `ior`"), "{e}");
    let e = scene_err(&m("opacity = 0.5\nreflect = [1.0, 1.0, 1.0]"));
    assert!(e.contains("semi-transparent material (`opacity` < 1) takes no `reflect`"), "{e}");
    let e = scene_err(&m("opacity = 1.5"));
    assert!(e.contains("`opacity` must be in [0, 1], got 1.5"), "{e}");
    let e = scene_err(&m("ior = -1.0"));
    assert!(e.contains("`ior` must be > 0"), "{e}");
    let e = scene_err(&m("reflect = [2.0, 0.0, 0.0]"));
    assert!(e.contains("`reflect` must be linear RGB"), "{e}");
    let e = scene_err(&format!("ray_depth = 0\n{}", m("")));
    assert!(e.contains("`ray_depth` must be 1 to 16"), "{e}");
    let e = scene_err(&format!("ray_depth = 17\n{}", m("")));
    assert!(e.contains("got 17"), "{e}");
}
