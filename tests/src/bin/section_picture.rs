//! The picture of `scenes/ball_perforation.toml` in docs/scene.md: a section of the run through
//! the plane y = 0, the frames of a run's fields.h5 side by side, each element whose initial
//! centroid lies within `SLAB` of that plane drawn as its outline in the x-z plane (its six
//! faces projected), filled by its equivalent plastic strain; failed elements (field `failed`
//! = 1) left out; the particles within `SLAB` of the plane (a failed element's, where its
//! block turns them into particles) drawn as discs of their size, filled likewise and outlined
//! in black. An SVG (no plotting library: polygons, circles and text).
//!
//! `cargo run --release -p tdyn-tests --bin section_picture -- OUT_DIR SLAB_M XHALF_M docs/img/ball_perforation.svg`
//!
//! (XHALF_M: only the elements whose initial centroid has |x| below it.)
use std::fmt::Write;
use tdyn_tests::frames::{read_frames, FACES};

/// Each panel's size, px.
const PANEL_PX: f64 = 200.0;
/// The colour scale: equivalent plastic strain from 0 to this.
const SCALE_MAX: f64 = 0.5;

/// Grey for an elastic element, then yellow to red with the plastic strain `ep`.
fn colour(ep: f64) -> String {
    if ep <= 0.0 {
        return "rgb(175,185,200)".into();
    }
    let t = (ep / SCALE_MAX).clamp(0.0, 1.0);
    format!("rgb(255,{:.0},{:.0})", 230.0 - 200.0 * t, 120.0 - 100.0 * t)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    assert!(
        args.len() == 5,
        "usage: section_picture OUT_DIR SLAB_M XHALF_M PICTURE.svg"
    );
    let out = std::path::Path::new(&args[1]);
    let slab: f64 = args[2].parse().expect("SLAB_M: a number (m)");
    let xhalf: f64 = args[3].parse().expect("XHALF_M: a number (m)");
    let fr = read_frames(out);
    let file = hdf5::File::open(out.join("fields.h5")).unwrap();
    let mut names = file.group("frames").unwrap().member_names().unwrap();
    names.sort();
    let x0 = &fr.positions[0];
    let centroid = |c: &[usize; 8], x: &[[f64; 3]]| -> [f64; 3] {
        std::array::from_fn(|k| c.iter().map(|&n| x[n][k]).sum::<f64>() / 8.0)
    };
    let in_slab: Vec<usize> = (0..fr.connectivity.len())
        .filter(|&e| {
            let c = centroid(&fr.connectivity[e], x0);
            c[1].abs() < slab && c[0].abs() < xhalf
        })
        .collect();
    // the drawing's box: the first frame's slab, 1.6 times as tall below (the ball goes down)
    let (mut xmin, mut xmax, mut zmin, mut zmax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &e in &in_slab {
        for &n in &fr.connectivity[e] {
            xmin = xmin.min(x0[n][0]);
            xmax = xmax.max(x0[n][0]);
            zmin = zmin.min(x0[n][2]);
            zmax = zmax.max(x0[n][2]);
        }
    }
    zmin -= 1.6 * (zmax - zmin);
    let px = PANEL_PX / (xmax - xmin).max(zmax - zmin);
    let height = (zmax - zmin) * px;
    let mut svg = String::new();
    writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{:.0}" height="{:.0}" font-family="sans-serif" font-size="13">"#,
        names.len() as f64 * (PANEL_PX + 10.0) + 10.0,
        height + 60.0
    )
    .unwrap();
    for (k, name) in names.iter().enumerate() {
        let g = file.group(&format!("frames/{name}")).unwrap();
        let ep: Vec<f64> = g
            .dataset("elements/plastic_strain")
            .unwrap()
            .read_raw()
            .unwrap();
        let failed: Vec<f64> = g
            .dataset("elements/failed")
            .map(|d| d.read_raw().unwrap())
            .unwrap_or_else(|_| vec![0.0; ep.len()]);
        let x = &fr.positions[k];
        let left = 10.0 + k as f64 * (PANEL_PX + 10.0);
        for &e in in_slab.iter().filter(|&&e| failed[e] == 0.0) {
            let fill = colour(if ep[e].is_nan() { 0.0 } else { ep[e] });
            for f in FACES {
                let pts: Vec<String> = f
                    .iter()
                    .map(|&i| {
                        let p = x[fr.connectivity[e][i]];
                        format!(
                            "{:.2},{:.2}",
                            left + (p[0] - xmin) * px,
                            20.0 + (zmax - p[2]) * px
                        )
                    })
                    .collect();
                writeln!(
                    svg,
                    r#"<polygon points="{}" fill="{fill}" stroke="{fill}" stroke-width="0.4"/>"#,
                    pts.join(" ")
                )
                .unwrap();
            }
        }
        if let (Ok(xp), Ok(hp)) = (
            g.dataset("particles/position")
                .and_then(|d| d.read_raw::<f64>()),
            g.dataset("particles/h").and_then(|d| d.read_raw::<f64>()),
        ) {
            let epp: Vec<f64> = g
                .dataset("particles/plastic_strain")
                .and_then(|d| d.read_raw())
                .unwrap_or_else(|_| vec![0.0; hp.len()]);
            for (i, h) in hp.iter().enumerate() {
                let p = &xp[3 * i..3 * i + 3];
                if p[1].abs() >= slab || p[0].abs() >= xhalf {
                    continue;
                }
                // the particle's size is h / 1.2 (its element's V^(1/3)); the disc its half
                let r = 0.5 * h / 1.2 * px;
                writeln!(
                    svg,
                    r#"<circle cx="{:.2}" cy="{:.2}" r="{r:.2}" fill="{}" stroke="black" stroke-width="0.4"/>"#,
                    left + (p[0] - xmin) * px,
                    20.0 + (zmax - p[2]) * px,
                    colour(if epp[i].is_nan() { 0.0 } else { epp[i] })
                )
                .unwrap();
            }
        }
        writeln!(
            svg,
            r#"<text x="{:.1}" y="14">t = {:.0} us</text>"#,
            left,
            fr.times[k] * 1e6
        )
        .unwrap();
    }
    writeln!(
        svg,
        r#"<text x="10" y="{:.1}">section y = 0 (elements within {:.2} mm); grey: elastic; yellow to red: plastic strain 0 to {SCALE_MAX}; failed elements removed (outlined discs: their particles, where they become particles)</text>"#,
        height + 45.0,
        slab * 1e3
    )
    .unwrap();
    svg.push_str("</svg>\n");
    std::fs::write(&args[4], svg).unwrap();
    eprintln!("{}: {} elements in the slab", args[4], in_slab.len());
}
