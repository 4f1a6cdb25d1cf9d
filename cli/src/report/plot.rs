//! The error-against-time plot as SVG, written by hand (a scatter and a line need no plotting
//! crate): each setting a dot, the Pareto front a line through its settings, time on a log axis.

use std::fmt::Write as _;

pub struct Point {
    pub label: String,
    pub time_ms: f64,
    pub psnr: f64,
    pub pareto: bool,
}

const W: f64 = 880.0;
const H: f64 = 440.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 340.0;
const TOP: f64 = 30.0;
const BOTTOM: f64 = 50.0;

pub fn svg(points: &[Point]) -> String {
    let finite: Vec<&Point> = points
        .iter()
        .filter(|p| p.time_ms.is_finite() && p.time_ms > 0.0 && p.psnr.is_finite())
        .collect();
    let (t0, t1) = finite.iter().fold((f64::MAX, f64::MIN), |(a, b), p| {
        (a.min(p.time_ms.log10()), b.max(p.time_ms.log10()))
    });
    let (p0, p1) = finite.iter().fold((f64::MAX, f64::MIN), |(a, b), p| {
        (a.min(p.psnr), b.max(p.psnr))
    });
    let (t0, t1) = (t0.floor(), t1.ceil().max(t0.floor() + 1.0));
    let (p0, p1) = ((p0 - 1.0).floor(), (p1 + 1.0).ceil());
    let x = |t: f64| LEFT + (t.log10() - t0) / (t1 - t0) * (W - LEFT - RIGHT);
    let y = |p: f64| TOP + (p1 - p) / (p1 - p0) * (H - TOP - BOTTOM);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" \
         font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    );
    // Axes, with a tick per decade of time and per 2 dB.
    let _ = writeln!(
        s,
        "<path d=\"M{LEFT} {TOP} V{} H{}\" stroke=\"black\" fill=\"none\"/>",
        H - BOTTOM,
        W - RIGHT
    );
    let mut decade = t0;
    while decade <= t1 {
        let px = x(10f64.powf(decade));
        let _ = writeln!(
            s,
            "<text x=\"{px:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            H - BOTTOM + 16.0,
            10f64.powf(decade)
        );
        decade += 1.0;
    }
    let mut db = p0;
    while db <= p1 {
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{db}</text>",
            LEFT - 6.0,
            y(db) + 4.0
        );
        db += 2.0;
    }
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{}\" text-anchor=\"middle\">time per frame, ms (log)</text>",
        (LEFT + W - RIGHT) / 2.0,
        H - 12.0
    );
    let _ = writeln!(
        s,
        "<text x=\"16\" y=\"{:.1}\" transform=\"rotate(-90 16 {:.1})\" text-anchor=\"middle\">PSNR against the truth, dB</text>",
        (TOP + H - BOTTOM) / 2.0,
        (TOP + H - BOTTOM) / 2.0
    );
    // The Pareto front, fastest first.
    let mut front: Vec<&&Point> = finite.iter().filter(|p| p.pareto).collect();
    front.sort_by(|a, b| a.time_ms.total_cmp(&b.time_ms));
    let path: Vec<String> = front
        .iter()
        .map(|p| format!("{:.1},{:.1}", x(p.time_ms), y(p.psnr)))
        .collect();
    let _ = writeln!(
        s,
        "<polyline points=\"{}\" stroke=\"#d33\" stroke-width=\"2\" fill=\"none\"/>",
        path.join(" ")
    );
    for p in &finite {
        let colour = if p.pareto { "#d33" } else { "#358" };
        let _ = writeln!(
            s,
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"4\" fill=\"{colour}\"><title>{}: {:.1} ms, {:.2} dB</title></circle>",
            x(p.time_ms),
            y(p.psnr),
            p.label,
            p.time_ms,
            p.psnr
        );
    }
    // The front's settings named beside the plot.
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{TOP}\" font-weight=\"bold\">Pareto front (red)</text>",
        W - RIGHT + 14.0
    );
    for (k, p) in front.iter().enumerate() {
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{:.1}\">{} — {:.0} ms, {:.1} dB</text>",
            W - RIGHT + 14.0,
            TOP + 16.0 * (k + 1) as f64,
            p.label,
            p.time_ms,
            p.psnr
        );
    }
    s + "</svg>\n"
}
