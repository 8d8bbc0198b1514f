//! The gallery's page: one self-contained `index.html` (no script, no remote resource) that
//! shows the built-in styles, then each experiment's pictures beside the numbers it printed
//! and the paper's claim. Every picture is a relative link to a PNG in the same folder.

/// A built-in style's picture.
pub struct StyleEntry {
    /// `long`.
    pub name: String,
    /// Its line from `wisptree styles`.
    pub description: String,
    /// The PNG's file name.
    pub file: String,
}

/// One run of an experiment: its key frame and its numbers.
pub struct Shot {
    /// The run's label.
    pub label: String,
    /// The PNG's file name; `None` if the run logged no frame.
    pub file: Option<String>,
    /// What `wisptree experiment` prints for the run.
    pub metrics: serde_json::Map<String, serde_json::Value>,
}

/// One experiment.
pub struct ExperimentEntry {
    /// `awt-fig7`.
    pub name: String,
    /// The paper, the figure, what it shows.
    pub description: String,
    /// What the numbers should show: the paper's claim, as a check.
    pub expectation: String,
    /// The pictures the experiment made of itself (PNG file names).
    pub pictures: Vec<String>,
    /// Its runs.
    pub runs: Vec<Shot>,
    /// Why it failed, if it did.
    pub error: Option<String>,
}

/// The whole page.
pub struct Page {
    /// `Some(scale)` when the runs were shortened to this fraction (`--quick`).
    pub quick: Option<f64>,
    /// The built-in styles.
    pub styles: Vec<StyleEntry>,
    /// The experiments, in `wisptree experiment --list` order.
    pub experiments: Vec<ExperimentEntry>,
}

const STYLE: &str = "body{font-family:sans-serif;margin:1.5em;max-width:1400px;color:#222}\
h2{margin-top:2em;border-bottom:1px solid #ccc}\
.row{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start}\
figure{margin:0;max-width:480px}figure img{max-width:100%;border:1px solid #ddd}\
figcaption{font-size:90%}.claim{background:#f4f4e8;padding:.5em 1em;border-left:4px solid #bb9}\
.numbers{font-family:monospace;font-size:85%;margin:.3em 0;padding-left:1.2em}\
.sheet img{max-width:100%}.error{color:#a00}.note{color:#666}";

/// The page's HTML.
pub fn html(page: &Page) -> String {
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">");
    h.push_str("<title>wisptree gallery</title>");
    h.push_str(&format!("<style>{STYLE}</style></head><body>\n"));
    h.push_str("<h1>wisptree gallery</h1>\n<p>Made by <code>wisptree gallery</code>: every ");
    h.push_str("built-in style at rest, then every experiment of <code>wisptree experiment");
    h.push_str("</code> with the numbers it printed and what they should show. A run's ");
    h.push_str("picture is its last frame.</p>\n");
    if let Some(scale) = page.quick {
        h.push_str(&format!(
            "<p class=\"note\"><b>Quick gallery</b>: every run shortened to {} of its length \
             (<code>--quick</code>); its numbers need not show the paper's point.</p>\n",
            esc(&format!("{scale}"))
        ));
    }
    h.push_str("<h2 id=\"styles\">Built-in styles</h2>\n<div class=\"row\">\n");
    for s in &page.styles {
        h.push_str(&format!(
            "<figure><img src=\"{}\" alt=\"{}\"><figcaption><b>{}</b>: {}</figcaption></figure>\n",
            esc(&s.file),
            esc(&s.name),
            esc(&s.name),
            esc(&s.description)
        ));
    }
    h.push_str("</div>\n");
    for e in &page.experiments {
        experiment(&mut h, e);
    }
    h.push_str("</body></html>\n");
    h
}

fn experiment(h: &mut String, e: &ExperimentEntry) {
    h.push_str(&format!(
        "<h2 id=\"{}\">{}</h2>\n<p>{}</p>\n<p class=\"claim\"><b>The paper's point</b> (what the \
         numbers should show): {}</p>\n<p class=\"note\"><code>wisptree experiment {} --save \
         {}.rrd</code> records it.</p>\n",
        esc(&e.name),
        esc(&e.name),
        esc(&e.description),
        esc(&e.expectation),
        esc(&e.name),
        esc(&e.name)
    ));
    if let Some(err) = &e.error {
        h.push_str(&format!("<p class=\"error\">failed: {}</p>\n", esc(err)));
    }
    for p in &e.pictures {
        h.push_str(&format!(
            "<p class=\"sheet\"><img src=\"{}\" alt=\"{} picture\"></p>\n",
            esc(p),
            esc(&e.name)
        ));
    }
    h.push_str("<div class=\"row\">\n");
    for r in &e.runs {
        h.push_str("<figure>");
        match &r.file {
            Some(f) => h.push_str(&format!(
                "<img src=\"{}\" alt=\"{} {}\">",
                esc(f),
                esc(&e.name),
                esc(&r.label)
            )),
            None => h.push_str("<p class=\"note\">(no frame)</p>"),
        }
        h.push_str(&format!(
            "<figcaption><b>{}</b><ul class=\"numbers\">",
            esc(&r.label)
        ));
        for (k, v) in &r.metrics {
            h.push_str(&format!("<li>{} = {}</li>", esc(k), esc(&v.to_string())));
        }
        h.push_str("</ul></figcaption></figure>\n");
    }
    h.push_str("</div>\n");
}

/// `s` with HTML's special characters escaped (text and attribute values alike).
fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            _ => o.push(c),
        }
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped_and_every_picture_is_linked() {
        let mut metrics = serde_json::Map::new();
        metrics.insert("crossings".into(), serde_json::json!(3));
        let page = Page {
            quick: None,
            styles: vec![StyleEntry {
                name: "long".into(),
                description: "a <b> & \"c\"".into(),
                file: "style_long.png".into(),
            }],
            experiments: vec![ExperimentEntry {
                name: "x-fig1".into(),
                description: "d".into(),
                expectation: "crossings < 1".into(),
                pictures: vec!["exp_x-fig1_sheet.png".into()],
                runs: vec![Shot {
                    label: "none".into(),
                    file: Some("exp_x-fig1_none.png".into()),
                    metrics,
                }],
                error: None,
            }],
        };
        let h = html(&page);
        assert!(h.contains("a &lt;b&gt; &amp; &quot;c&quot;"), "{h}");
        assert!(h.contains("crossings &lt; 1"));
        assert!(h.contains("crossings = 3"));
        for f in [
            "style_long.png",
            "exp_x-fig1_sheet.png",
            "exp_x-fig1_none.png",
        ] {
            assert!(h.contains(&format!("src=\"{f}\"")), "{f}");
        }
    }
}
