//! The Largest Feasible Region picture: V_h over the CBV's position in the
//! ego frame ([`LfrPanel`]s from `eval::feasibility_accuracy`), one heat-map
//! panel per (speed, CBV heading), blue where V_h ≤ 0 (feasible), red where
//! V_h > 0, black where the boxes overlap, the ego's box outlined green.
//! Written by `safer feasibility-eval` as `docs/feasibility-lfr.svg`.

use std::fmt::Write as _;

use crate::eval::feasibility_accuracy::{LFR_CAR, LFR_HEADINGS, LfrGrid, LfrPanel};
use crate::models::feasibility::VIOLATION_COST;

/// Pixels per grid cell.
const CELL_PX: f64 = 8.0;

/// Fill of a cell: black where the boxes overlap, else white → red as V_h
/// rises to M, white → blue as it falls to −M, grey when not a number.
fn cell_colour(value: f32, overlapping: bool) -> String {
    let t = (f64::from(value) / VIOLATION_COST).clamp(-1.0, 1.0);
    if overlapping {
        "black".to_string()
    } else if t.is_nan() {
        "grey".to_string()
    } else if t > 0.0 {
        format!("rgb(255,{0},{0})", (255.0 * (1.0 - t)) as u8)
    } else {
        format!("rgb({0},{0},255)", (255.0 * (1.0 + t)) as u8)
    }
}

/// The picture of `panels`, laid out row by row with one column per CBV
/// heading of the figure.
pub fn render_lfr_svg(panels: &[LfrPanel]) -> String {
    let grid = panels.first().map_or(LfrGrid::FIGURE, |p| p.grid);
    let (x_range, y_range, cell_m) = (grid.x_range_m, grid.y_range_m, grid.cell_m);
    let (nx, ny) = grid.cells();
    let columns = LFR_HEADINGS.len();
    let rows = panels.len().div_ceil(columns);
    let px = CELL_PX;
    let (panel_w, panel_h) = (nx as f64 * px, ny as f64 * px);
    let mut svg = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" font-family="sans-serif" font-size="12">
<text x="10" y="16">V_h over the CBV's position in the ego frame (ego at the origin, heading +x; x {}..{} m, y {}..{} m). Blue: feasible (V_h ≤ 0); red: infeasible. CBV speed = ego speed.</text>
"#,
        columns as f64 * (panel_w + 20.0) + 20.0,
        rows as f64 * (panel_h + 40.0) + 40.0,
        x_range.0,
        x_range.1,
        y_range.0,
        y_range.1
    );
    for (k, panel) in panels.iter().enumerate() {
        let (row, col) = (k / columns, k % columns);
        let (ox, oy) = (20.0 + col as f64 * (panel_w + 20.0), 40.0 + row as f64 * (panel_h + 40.0));
        let _ = write!(
            svg,
            r#"<text x="{ox}" y="{}">ego and CBV at {} m/s, CBV {}</text>"#,
            oy - 4.0,
            panel.speed_mps,
            panel.label
        );
        for (c, (value, overlapping)) in panel.values.iter().zip(&panel.overlapping).enumerate() {
            let (i, j) = (c % nx.max(1), c / nx.max(1));
            let _ = write!(
                svg,
                r#"<rect x="{:.1}" y="{:.1}" width="{px}" height="{px}" fill="{}"/>"#,
                ox + i as f64 * px,
                oy + j as f64 * px,
                cell_colour(*value, *overlapping)
            );
        }
        // The ego's box.
        let (ex, ey) = (ox + (0.0 - x_range.0) / cell_m * px, oy + (y_range.1 - 0.0) / cell_m * px);
        let (l, w) = (LFR_CAR.length_m, LFR_CAR.width_m);
        let _ = write!(
            svg,
            r#"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="none" stroke="green" stroke-width="2"/>"#,
            ex - l / 2.0 / cell_m * px,
            ey - w / 2.0 / cell_m * px,
            l / cell_m * px,
            w / cell_m * px
        );
    }
    svg += "</svg>\n";
    svg
}

#[cfg(test)]
mod tests {
    use super::*;

    fn panel(speed_mps: f64, label: &'static str, values: Vec<f32>) -> LfrPanel {
        let grid = LfrGrid { x_range_m: (-1.0, 1.0), y_range_m: (-1.0, 1.0), cell_m: 1.0 };
        let overlapping = vec![false, true, false, false];
        LfrPanel { speed_mps, cbv_heading_rad: 0.0, label, grid, values, overlapping }
    }

    #[test]
    fn cells_are_coloured_by_the_sign_of_v_h() {
        assert_eq!(cell_colour(16.0, false), "rgb(255,0,0)");
        assert_eq!(cell_colour(-16.0, false), "rgb(0,0,255)");
        assert_eq!(cell_colour(0.0, false), "rgb(255,255,255)");
        assert_eq!(cell_colour(8.0, true), "black");
        assert_eq!(cell_colour(f32::NAN, false), "grey");
    }

    #[test]
    fn panels_are_laid_out_one_column_per_heading() {
        let panels = vec![
            panel(5.0, "same heading", vec![16.0, 0.0, -16.0, 1.0]),
            panel(5.0, "crossing from the right", vec![0.0; 4]),
            panel(10.0, "same heading", vec![0.0; 4]),
        ];
        let svg = render_lfr_svg(&panels);
        // 2 columns of 2 cells × 8 px (+ 20 px gaps), 2 rows of 16 px (+ 40 px).
        assert!(svg.starts_with(r#"<svg xmlns="http://www.w3.org/2000/svg" width="92" height="152""#), "{svg}");
        assert!(svg.contains(r#"<text x="56" y="36">ego and CBV at 5 m/s, CBV crossing from the right</text>"#));
        assert!(svg.contains(r#"<text x="20" y="92">ego and CBV at 10 m/s, CBV same heading</text>"#));
        assert!(svg.contains(r#"<rect x="20.0" y="40.0" width="8" height="8" fill="rgb(255,0,0)"/>"#));
        assert!(svg.contains(r#"<rect x="28.0" y="40.0" width="8" height="8" fill="black"/>"#));
        assert!(svg.contains(r#"<rect x="20.0" y="48.0" width="8" height="8" fill="rgb(0,0,255)"/>"#));
        assert_eq!(svg.matches("stroke=\"green\"").count(), 3, "one ego box per panel");
        assert!(svg.ends_with("</svg>\n"));
    }
}
