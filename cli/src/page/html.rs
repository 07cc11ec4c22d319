//! The page's HTML: one self-contained file (inline CSS, no script, no fonts or anything else
//! fetched) that links the crops in [`DIR`](super::DIR) beside it. Every text that comes from
//! outside (scene and object names of loaded meshes) is escaped.

use super::{Column, SceneEvents, Section, Tile, DIR, ERROR_MAX, WINDOW};
use std::fmt::Write as _;
use vrrt_scene::image::Image;

/// File name of the heatmap's colour scale inside [`DIR`](super::DIR).
pub const LEGEND: &str = "legend.png";

/// What the page is made of.
pub struct Meta<'a> {
    /// The backend whose frames are shown.
    pub backend: &'a str,
    /// Reference samples per pixel.
    pub spp: u32,
    /// Every scene's events.
    pub scenes: &'a [SceneEvents],
    /// The sections, in bench order.
    pub sections: &'a [Section],
}

const STYLE: &str = "body{font-family:sans-serif;margin:1.5em;color:#222;background:#fafafa}\
table{border-collapse:collapse}td,th{padding:2px 4px;vertical-align:top;font-size:12px}\
th{text-align:left}th.frame{text-align:right;white-space:nowrap}tr.errors td{padding-bottom:10px}\
figure{margin:0}img{display:block;image-rendering:pixelated}figcaption{color:#555}\
.note{color:#555}section{margin:2em 0}";

/// `text` with `&`, `<`, `>`, `"` and `'` escaped, fit for element text and quoted attributes.
pub fn escape(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => s.push_str("&amp;"),
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '"' => s.push_str("&quot;"),
            '\'' => s.push_str("&#39;"),
            c => s.push(c),
        }
    }
    s
}

/// The heatmap's scale as a strip: 0 at the left to `max` at 10/11 of the width, the
/// "above" white after it.
pub fn legend(max: f32) -> Image {
    let (w, h) = (220, 14);
    let data = (0..w * h)
        .map(|i| (i % w) as f32 / (w - 21) as f32 * max)
        .collect();
    Image::new(w, h, 1, data).expect("a fixed non-empty strip")
}

/// The whole page.
pub fn page(m: &Meta<'_>) -> String {
    let mut s = String::new();
    let offsets: Vec<String> = WINDOW.iter().map(|o| format!("+{o}")).collect();
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>vrrt bench: moving regions</title>\n<style>{STYLE}</style>\n</head>\n<body>\n\
         <h1>vrrt bench: moving regions</h1>\n\
         <p>For every scene, signal and ray budget of the bench, the frames {} after each event \
         of the scene (an object or a light starts moving, the camera cuts), cropped to what \
         moves: an object's footprint over those frames, the whole view for cuts and lights. \
         Columns: the {} spp reference, the raw samples, each configuration; crops are \
         upscaled with nearest neighbour and shown as every PNG of <code>vrrt</code> is \
         (linear values clamped to [0,&nbsp;1], sRGB-encoded). Below each image its error \
         |test&nbsp;&minus;&nbsp;reference| (mean over channels) on one scale for every \
         configuration; below the reference the moving mask (reference changed or \
         disoccluded). Captions: the crop's relMSE (as the bench's, &epsilon;&nbsp;=&nbsp;0.01) \
         and mean error. Frames of the {} backend.</p>\n\
         <p><img src=\"{DIR}/{LEGEND}\" alt=\"error scale\" width=\"220\" height=\"14\">\
         error 0 (black) &hellip; {ERROR_MAX} (red); white: above {ERROR_MAX}; magenta: not \
         finite</p>\n",
        offsets.join(", "),
        m.spp,
        escape(m.backend)
    );
    events_list(&mut s, m);
    s.push_str("<h2>Sections</h2>\n<ol>\n");
    for (i, sec) in m.sections.iter().enumerate() {
        let _ = writeln!(
            s,
            "<li><a href=\"#s{i:03}\">{}</a></li>",
            escape(&heading(sec))
        );
    }
    s.push_str("</ol>\n");
    for (i, sec) in m.sections.iter().enumerate() {
        section(&mut s, i, sec);
    }
    s.push_str("</body>\n</html>\n");
    s
}

fn events_list(s: &mut String, m: &Meta<'_>) {
    s.push_str("<h2>Events</h2>\n<ul>\n");
    for sc in m.scenes {
        let events: Vec<String> = sc
            .events
            .iter()
            .map(|e| {
                let shown = if e.frame < sc.frames {
                    ""
                } else {
                    " (not rendered)"
                };
                format!("frame {} {}{shown}", e.frame, e.label)
            })
            .collect();
        let events = if events.is_empty() {
            "none (nothing starts moving and the camera does not cut)".to_string()
        } else {
            events.join("; ")
        };
        let _ = writeln!(
            s,
            "<li>{} ({} frames rendered): {}</li>",
            escape(&sc.key),
            sc.frames,
            escape(&events)
        );
    }
    s.push_str("</ul>\n");
}

fn heading(sec: &Section) -> String {
    format!(
        "{} · {} · {} rpp · frame {}: {}",
        sec.scene, sec.signal, sec.budget, sec.event.frame, sec.event.label
    )
}

fn section(s: &mut String, i: usize, sec: &Section) {
    let _ = writeln!(
        s,
        "<section id=\"s{i:03}\">\n<h3>{}</h3>",
        escape(&heading(sec))
    );
    let Some(crop) = sec.crop else {
        let _ = writeln!(
            s,
            "<p class=\"note\">Out of view in frames {:?}: nothing to show.</p>\n</section>",
            sec.rows
        );
        return;
    };
    let _ = writeln!(
        s,
        "<p class=\"note\">Crop x {}&ndash;{}, y {}&ndash;{} of {}&times;{}, shown &times;{}.</p>",
        crop.x0,
        crop.x1,
        crop.y0,
        crop.y1,
        sec.size.0,
        sec.size.1,
        crop.display_scale()
    );
    s.push_str("<table>\n<tr><th>frame</th>");
    for c in &sec.columns {
        let _ = write!(s, "<th>{}</th>", escape(&c.title));
    }
    s.push_str("</tr>\n");
    for (r, &frame) in sec.rows.iter().enumerate() {
        let _ = write!(
            s,
            "<tr><th class=\"frame\" rowspan=\"2\">{frame}<br>+{}</th>",
            frame - sec.event.frame
        );
        cells(s, &sec.columns, |c| (c.images[r].as_ref(), c.title.clone()));
        s.push_str("</tr>\n<tr class=\"errors\">");
        cells(s, &sec.columns, |c| {
            let alt = if c.key == "reference" {
                "moving mask".to_string()
            } else {
                format!("error of {}", c.title)
            };
            (c.errors[r].as_ref(), alt)
        });
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n</section>\n");
}

/// One cell per column: `tile` gives the column's image of the row and its alternative text.
fn cells(s: &mut String, columns: &[Column], tile: impl Fn(&Column) -> (Option<&Tile>, String)) {
    for c in columns {
        let (Some(t), alt) = tile(c) else {
            s.push_str("<td></td>");
            continue;
        };
        let _ = write!(
            s,
            "<td><figure><img src=\"{DIR}/{}\" alt=\"{}\">",
            escape(&t.file),
            escape(&alt)
        );
        if !t.caption.is_empty() {
            let _ = write!(s, "<figcaption>{}</figcaption>", escape(&t.caption));
        }
        s.push_str("</figure></td>");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_covers_markup_and_quotes() {
        assert_eq!(
            escape(r#"<b>"box" & 'ball'</b>"#),
            "&lt;b&gt;&quot;box&quot; &amp; &#39;ball&#39;&lt;/b&gt;"
        );
        assert_eq!(escape("sliding box · ü"), "sliding box · ü");
    }

    #[test]
    fn the_legend_reaches_the_maximum_then_goes_over() {
        let l = legend(ERROR_MAX);
        let row = &l.data()[..l.width()];
        assert_eq!(row[0], 0.0);
        assert!((row[l.width() - 21] - ERROR_MAX).abs() < 1e-6);
        assert!(row[l.width() - 1] > ERROR_MAX);
    }
}
