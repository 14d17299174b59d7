/// A Markdown table. Cells are escaped for `|`.
pub fn markdown_table(headers: &[&str], rows: &[Vec<String>]) -> String {
    let esc = |s: &str| s.replace('|', "\\|");
    let mut out = String::new();
    out.push_str(&format!(
        "| {} |\n",
        headers
            .iter()
            .map(|h| esc(h))
            .collect::<Vec<_>>()
            .join(" | ")
    ));
    out.push_str(&format!("|{}\n", "---|".repeat(headers.len())));
    for r in rows {
        out.push_str(&format!(
            "| {} |\n",
            r.iter().map(|c| esc(c)).collect::<Vec<_>>().join(" | ")
        ));
    }
    out
}

/// One block of an HTML report page.
#[derive(Debug, Clone)]
pub enum Section {
    Heading(String),
    Paragraph(String),
    /// Pre-formatted text (a table printed for the terminal, a command).
    Pre(String),
    /// A bulleted list.
    List(Vec<String>),
    /// An image file relative to the page, with a caption.
    Image {
        src: String,
        caption: String,
    },
    /// A table: headers and rows.
    Table {
        headers: Vec<String>,
        rows: Vec<Vec<String>>,
    },
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Escaped text with Markdown's inline code (`` `name` ``) as `<code>`;
/// an unpaired backtick stays as it is.
fn inline(s: &str) -> String {
    let parts: Vec<&str> = s.split('`').collect();
    // An even number of backticks splits the text into an odd number of parts.
    let paired = parts.len() % 2 == 1;
    if !paired {
        return esc(s);
    }
    parts
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if i % 2 == 1 {
                format!("<code>{}</code>", esc(p))
            } else {
                esc(p)
            }
        })
        .collect()
}

/// A self-contained HTML page (no scripts, no external resources).
pub fn html_page(title: &str, sections: &[Section]) -> String {
    let mut body = String::new();
    for s in sections {
        match s {
            Section::Heading(h) => body.push_str(&format!("<h2>{}</h2>\n", inline(h))),
            Section::Paragraph(p) => body.push_str(&format!("<p>{}</p>\n", inline(p))),
            Section::Pre(p) => body.push_str(&format!("<pre>{}</pre>\n", esc(p))),
            Section::List(items) => {
                body.push_str("<ul>\n");
                for i in items {
                    body.push_str(&format!("<li>{}</li>\n", inline(i)));
                }
                body.push_str("</ul>\n");
            }
            Section::Image { src, caption } => body.push_str(&format!(
                "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>\n",
                esc(src),
                esc(&caption.replace('`', "")),
                inline(caption)
            )),
            Section::Table { headers, rows } => {
                body.push_str("<table>\n<tr>");
                for h in headers {
                    body.push_str(&format!("<th>{}</th>", inline(h)));
                }
                body.push_str("</tr>\n");
                for r in rows {
                    body.push_str("<tr>");
                    for c in r {
                        body.push_str(&format!("<td>{}</td>", inline(c)));
                    }
                    body.push_str("</tr>\n");
                }
                body.push_str("</table>\n");
            }
        }
    }
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\n<style>\
body{{font-family:sans-serif;max-width:1150px;margin:2em auto;color:#222}}\
table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #bbb;padding:4px 8px;text-align:right}}\
th{{background:#eee}}img{{max-width:100%;border:1px solid #ddd}}figcaption{{color:#555;font-size:90%}}\
pre{{background:#f6f6f6;padding:8px;overflow-x:auto}}</style></head>\n<body><h1>{t}</h1>\n{body}</body></html>\n",
        t = esc(title)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_table_shape() {
        let t = markdown_table(&["a", "b"], &[vec!["1".into(), "x|y".into()]]);
        assert_eq!(t, "| a | b |\n|---|---|\n| 1 | x\\|y |\n");
    }

    #[test]
    fn html_escapes_text() {
        let p = html_page("r<1>", &[Section::Paragraph("a & b".into())]);
        assert!(p.contains("r&lt;1&gt;") && p.contains("a &amp; b"));
    }

    #[test]
    fn html_shows_inline_code_not_backticks() {
        let p = html_page(
            "t",
            &[
                Section::Paragraph("Scenario `papers` <1>".into()),
                Section::List(vec!["`ekf-reset`: chen2023".into()]),
                Section::Paragraph("one ` alone".into()),
            ],
        );
        assert!(p.contains("Scenario <code>papers</code> &lt;1&gt;"), "{p}");
        assert!(
            p.contains("<li><code>ekf-reset</code>: chen2023</li>"),
            "{p}"
        );
        assert!(p.contains("one ` alone"), "{p}");
    }
}
