//! The picture of `scenes/plate_hole.toml` in docs/meshing.md: the plate's top face (its
//! largest z) in the last frame of a run's fields.h5, each element face there filled by its
//! element's sigma_yy over the remote traction, the quarter mirrored into the whole plate, as
//! an SVG (no plotting library: polygons and text).
//!
//! `cargo run --release -p tdyn-tests --bin plate_picture -- OUT_DIR PULL_PA docs/img/plate_hole.svg`
use std::fmt::Write;
use tdyn_tests::frames::{last_frame, read_frames, FACES};

/// Picture size (px) and the margin for the colour bar.
const WIDTH_PX: f64 = 720.0;
const BAR_PX: f64 = 120.0;
/// The colour scale: sigma_yy / remote from 0 to this.
const SCALE_MAX: f64 = 3.5;

/// The colour of a stress ratio `v` (sigma_yy over the remote stress): blue at 0, white at 1
/// (the remote stress), red at `SCALE_MAX`, linear between.
fn colour(v: f64) -> String {
    let v = v.clamp(0.0, SCALE_MAX);
    let (r, g, b) = if v < 1.0 {
        (40.0 + 215.0 * v, 80.0 + 175.0 * v, 200.0 + 55.0 * v)
    } else {
        let t = (v - 1.0) / (SCALE_MAX - 1.0);
        (255.0, 255.0 - 215.0 * t, 255.0 - 225.0 * t)
    };
    format!("rgb({:.0},{:.0},{:.0})", r, g, b)
}

/// The top faces (4 node ids) of the elements, with their element.
fn top_faces(x0: &[[f64; 3]], conn: &[[usize; 8]]) -> Vec<(usize, [usize; 4])> {
    let z_top = x0.iter().map(|p| p[2]).fold(f64::MIN, f64::max);
    let tol = 1e-9 * (1.0 + z_top.abs());
    let mut faces = Vec::new();
    for (e, c) in conn.iter().enumerate() {
        for f in FACES {
            let q = f.map(|i| c[i]);
            if q.iter().all(|&n| x0[n][2] > z_top - tol) {
                faces.push((e, q));
            }
        }
    }
    faces
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    assert!(
        args.len() == 4,
        "usage: plate_picture OUT_DIR PULL_PA PICTURE.svg"
    );
    let out = std::path::Path::new(&args[1]);
    let pull: f64 = args[2].parse().expect("PULL_PA: a number (Pa)");
    let fr = read_frames(out);
    let g = last_frame(out);
    let stress: Vec<f64> = g.dataset("elements/stress").unwrap().read_raw().unwrap();
    let x0 = &fr.positions[0];
    let faces = top_faces(x0, &fr.connectivity);
    let (xmax, ymax) = x0
        .iter()
        .fold((0.0f64, 0.0f64), |(a, b), p| (a.max(p[0]), b.max(p[1])));
    // The whole plate is [-xmax, xmax] x [-ymax, ymax], drawn with y up.
    let px = (WIDTH_PX - BAR_PX) / (2.0 * xmax);
    let height = 2.0 * ymax * px;
    let mut svg = String::new();
    writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH_PX:.0}" height="{:.0}" font-family="sans-serif" font-size="13">"#,
        height + 40.0
    )
    .unwrap();
    for (e, q) in &faces {
        let fill = colour(stress[6 * e + 1] / pull);
        for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)] {
            let pts: Vec<String> = q
                .iter()
                .map(|&n| {
                    let (x, y) = (sx * x0[n][0], sy * x0[n][1]);
                    format!("{:.2},{:.2}", (x + xmax) * px, (ymax - y) * px + 20.0)
                })
                .collect();
            writeln!(
                svg,
                r#"<polygon points="{}" fill="{fill}" stroke="{fill}" stroke-width="0.3"/>"#,
                pts.join(" ")
            )
            .unwrap();
        }
    }
    // The colour bar, 0 to SCALE_MAX, labelled every 0.5.
    let (bx, steps) = (WIDTH_PX - BAR_PX + 30.0, 70);
    for k in 0..steps {
        let v = k as f64 / steps as f64;
        let y = 20.0 + (1.0 - v) * height - height / steps as f64;
        let v = v * SCALE_MAX;
        writeln!(
            svg,
            r#"<rect x="{bx:.1}" y="{y:.2}" width="20" height="{:.2}" fill="{}"/>"#,
            height / steps as f64 + 0.5,
            colour(v + 0.5 * SCALE_MAX / steps as f64)
        )
        .unwrap();
    }
    for k in 0..=(2.0 * SCALE_MAX) as usize {
        let v = 0.5 * k as f64;
        let y = 20.0 + (1.0 - v / SCALE_MAX) * height;
        writeln!(
            svg,
            r#"<text x="{:.1}" y="{:.1}">{v:.1}</text>"#,
            bx + 26.0,
            y + 4.0
        )
        .unwrap();
    }
    writeln!(
        svg,
        r#"<text x="{bx:.1}" y="14">&#963;yy / &#963;</text><text x="4" y="{:.1}">plate with a hole, gmsh's default tetrahedra (each run as 4 hexahedra); elements' &#963;yy over the remote traction &#963;, top face</text>"#,
        height + 36.0
    )
    .unwrap();
    svg.push_str("</svg>\n");
    std::fs::write(&args[3], svg).unwrap();
    eprintln!("{}: {} faces", args[3], faces.len());
}
