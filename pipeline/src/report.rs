//! The report: sections in pipeline order, each of paragraphs, tables and figures, rendered as Markdown
//! (`report.md`, the figures beside it as SVG files) and as one self-contained HTML page (`report.html`:
//! inline CSS and SVG, no external assets, opens offline). Every table and figure names the file it came
//! from.

use crate::svg::escape;

/// A figure: an SVG file beside the report, drawn inline in the HTML.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// The SVG file, relative to the report.
    pub file: String,
    /// The SVG text.
    pub svg: String,
    /// What it shows.
    pub caption: String,
    /// The file(s) it was drawn from, relative to the report.
    pub source: Vec<String>,
}

/// A table.
#[derive(Debug, Clone, PartialEq)]
pub struct TableBlock {
    /// Column headers.
    pub header: Vec<String>,
    /// Rows of cells.
    pub rows: Vec<Vec<String>>,
    /// The file(s) its numbers come from.
    pub source: Vec<String>,
}

/// One block of a section.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A paragraph (`code` in backticks; **bold** in double stars).
    Para(String),
    /// A table.
    Table(TableBlock),
    /// A figure.
    Figure(Figure),
    /// A list of items.
    List(Vec<String>),
}

/// One section: a stage of the pipeline.
#[derive(Debug, Clone, PartialEq)]
pub struct Section {
    /// Title.
    pub title: String,
    /// Anchor id (`stage-…`).
    pub id: String,
    /// Blocks in order.
    pub blocks: Vec<Block>,
}

impl Section {
    /// A section.
    pub fn new(title: &str, id: &str) -> Self {
        Self {
            title: title.to_string(),
            id: id.to_string(),
            blocks: Vec::new(),
        }
    }

    /// Adds a paragraph.
    pub fn para(&mut self, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Para(text.into()));
        self
    }

    /// Adds a table.
    pub fn table(
        &mut self,
        header: &[&str],
        rows: Vec<Vec<String>>,
        source: &[String],
    ) -> &mut Self {
        self.blocks.push(Block::Table(TableBlock {
            header: header.iter().map(|s| s.to_string()).collect(),
            rows,
            source: source.to_vec(),
        }));
        self
    }

    /// Adds a figure.
    pub fn figure(&mut self, f: Figure) -> &mut Self {
        self.blocks.push(Block::Figure(f));
        self
    }

    /// Adds a list.
    pub fn list(&mut self, items: Vec<String>) -> &mut Self {
        self.blocks.push(Block::List(items));
        self
    }
}

/// The whole report.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Report {
    /// Title.
    pub title: String,
    /// The answer, first (the headline).
    pub headline: String,
    /// How it was made: `(what, value)` — version, command, seeds, machine.
    pub made_by: Vec<(String, String)>,
    /// The flow picture.
    pub flow: Option<Figure>,
    /// Sections in pipeline order.
    pub sections: Vec<Section>,
}

fn sources_md(src: &[String]) -> String {
    src.iter()
        .map(|s| format!("`{s}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Inline Markdown (`code`, **bold**) to HTML, escaping the rest.
fn inline_html(s: &str) -> String {
    let mut out = String::new();
    let mut code = false;
    for (i, part) in s.split('`').enumerate() {
        if i > 0 {
            out.push_str(if code { "</code>" } else { "<code>" });
            code = !code;
        }
        if code {
            out.push_str(&escape(part));
        } else {
            let mut bold = false;
            for (j, p) in part.split("**").enumerate() {
                if j > 0 {
                    out.push_str(if bold { "</b>" } else { "<b>" });
                    bold = !bold;
                }
                out.push_str(&escape(p));
            }
            if bold {
                out.push_str("</b>");
            }
        }
    }
    if code {
        out.push_str("</code>");
    }
    out
}

fn source_links(src: &[String]) -> String {
    src.iter()
        .map(|s| format!("<a href=\"{}\"><code>{}</code></a>", escape(s), escape(s)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Strips an XML declaration so the SVG can sit inside HTML.
fn inline_svg(svg: &str) -> &str {
    match svg.find("<svg") {
        Some(i) => &svg[i..],
        None => svg,
    }
}

impl Report {
    /// The report as Markdown; figures are linked as their SVG files.
    pub fn markdown(&self) -> String {
        let mut s = format!("# {}\n\n{}\n\n", self.title, self.headline);
        for (k, v) in &self.made_by {
            s.push_str(&format!("- {k}: {v}\n"));
        }
        s.push('\n');
        if let Some(f) = &self.flow {
            s.push_str(&format!("![{}]({})\n\n", f.caption, f.file));
        }
        s.push_str("Contents: ");
        s.push_str(
            &self
                .sections
                .iter()
                .map(|x| format!("[{}](#{})", x.title, x.id))
                .collect::<Vec<_>>()
                .join(" · "),
        );
        s.push_str("\n\n");
        for sec in &self.sections {
            s.push_str(&format!("<a id=\"{}\"></a>\n## {}\n\n", sec.id, sec.title));
            for b in &sec.blocks {
                match b {
                    Block::Para(p) => s.push_str(&format!("{p}\n\n")),
                    Block::List(items) => {
                        for i in items {
                            s.push_str(&format!("- {i}\n"));
                        }
                        s.push('\n');
                    }
                    Block::Table(t) => {
                        s.push_str(&format!("| {} |\n", t.header.join(" | ")));
                        s.push_str(&format!(
                            "|{}\n",
                            t.header.iter().map(|_| "---|").collect::<String>()
                        ));
                        for r in &t.rows {
                            s.push_str(&format!("| {} |\n", r.join(" | ")));
                        }
                        s.push_str(&format!("\nFrom {}.\n\n", sources_md(&t.source)));
                    }
                    Block::Figure(f) => {
                        s.push_str(&format!(
                            "![{}]({})\n\n*{}* From {}.\n\n",
                            f.caption,
                            f.file,
                            f.caption,
                            sources_md(&f.source)
                        ));
                    }
                }
            }
        }
        s
    }

    /// The report as one self-contained HTML page (inline CSS and SVG; links only to the files beside
    /// it and to its own sections).
    pub fn html(&self) -> String {
        let mut s = String::from(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n",
        );
        s.push_str(&format!("<title>{}</title>\n", escape(&self.title)));
        s.push_str(
            "<style>\nbody{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222;line-height:1.45}\nh1{font-size:1.7em}h2{border-bottom:1px solid #ddd;padding-bottom:.2em;margin-top:2em}\n.headline{background:#eef5fc;border-left:4px solid #1f77b4;padding:.8em 1em;font-size:1.05em}\ntable{border-collapse:collapse;margin:.6em 0;font-size:.92em}th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left}th{background:#f4f4f4}\nfigure{margin:1.2em 0}figure svg{width:100%;height:auto;border:1px solid #eee}figcaption{font-size:.9em;color:#444}\n.src{font-size:.85em;color:#555}code{background:#f5f5f5;padding:0 .2em}nav a{margin-right:.8em}\n</style>\n</head>\n<body>\n",
        );
        s.push_str(&format!("<h1>{}</h1>\n", escape(&self.title)));
        s.push_str(&format!(
            "<p class=\"headline\" id=\"headline\">{}</p>\n<ul>\n",
            inline_html(&self.headline)
        ));
        for (k, v) in &self.made_by {
            s.push_str(&format!("<li>{}: {}</li>\n", escape(k), inline_html(v)));
        }
        s.push_str("</ul>\n");
        if let Some(f) = &self.flow {
            s.push_str(&format!(
                "<figure id=\"flow\">{}<figcaption>{}</figcaption></figure>\n",
                inline_svg(&f.svg),
                inline_html(&f.caption)
            ));
        }
        s.push_str("<nav>");
        for sec in &self.sections {
            s.push_str(&format!(
                "<a href=\"#{}\">{}</a>",
                escape(&sec.id),
                escape(&sec.title)
            ));
        }
        s.push_str("</nav>\n");
        for sec in &self.sections {
            s.push_str(&format!(
                "<section id=\"{}\">\n<h2>{}</h2>\n",
                escape(&sec.id),
                escape(&sec.title)
            ));
            for b in &sec.blocks {
                match b {
                    Block::Para(p) => s.push_str(&format!("<p>{}</p>\n", inline_html(p))),
                    Block::List(items) => {
                        s.push_str("<ul>\n");
                        for i in items {
                            s.push_str(&format!("<li>{}</li>\n", inline_html(i)));
                        }
                        s.push_str("</ul>\n");
                    }
                    Block::Table(t) => {
                        s.push_str("<table>\n<tr>");
                        for h in &t.header {
                            s.push_str(&format!("<th>{}</th>", inline_html(h)));
                        }
                        s.push_str("</tr>\n");
                        for r in &t.rows {
                            s.push_str("<tr>");
                            for c in r {
                                s.push_str(&format!("<td>{}</td>", inline_html(c)));
                            }
                            s.push_str("</tr>\n");
                        }
                        s.push_str(&format!(
                            "</table>\n<p class=\"src\">From {}.</p>\n",
                            source_links(&t.source)
                        ));
                    }
                    Block::Figure(f) => {
                        s.push_str(&format!(
                            "<figure>{}<figcaption>{} <span class=\"src\">From {}; file <a href=\"{}\"><code>{}</code></a>.</span></figcaption></figure>\n",
                            inline_svg(&f.svg),
                            inline_html(&f.caption),
                            source_links(&f.source),
                            escape(&f.file),
                            escape(&f.file)
                        ));
                    }
                }
            }
            s.push_str("</section>\n");
        }
        s.push_str("</body>\n</html>\n");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inline_markup_is_escaped_and_converted() {
        assert_eq!(
            inline_html("a `b<c` **d** & e"),
            "a <code>b&lt;c</code> <b>d</b> &amp; e"
        );
        let mut r = Report {
            title: "t".into(),
            headline: "h".into(),
            ..Default::default()
        };
        let mut sec = Section::new("One", "stage-one");
        sec.table(
            &["a", "b"],
            vec![vec!["1".into(), "2".into()]],
            &["x.csv".into()],
        );
        r.sections.push(sec);
        let md = r.markdown();
        assert!(
            md.contains("| a | b |") && md.contains("From `x.csv`."),
            "{md}"
        );
        let html = r.html();
        assert!(html.contains("<a href=\"#stage-one\">One</a>") && html.contains("href=\"x.csv\""));
    }
}
