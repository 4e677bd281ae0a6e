//! The Markdown the reports write ([`crate::reconstruction::ReconstructRunReport::markdown`] and
//! the others), as HTML: headings, paragraphs, pipe tables, `-` lists, fenced code, and inline
//! `code` and `**bold**`. Not a general Markdown parser: the reports use nothing else, and
//! everything else comes out as escaped text, never as markup.

/// Escapes `&`, `<`, `>` and `"` for HTML text and attribute values.
pub fn escape(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => s.push_str("&amp;"),
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '"' => s.push_str("&quot;"),
            c => s.push(c),
        }
    }
    s
}

/// One line's inline markup: `code` spans, then `**bold**` outside them; the rest escaped.
fn inline(text: &str) -> String {
    let mut out = String::new();
    for (i, part) in text.split('`').enumerate() {
        if i % 2 == 1 {
            out.push_str("<code>");
            out.push_str(&escape(part));
            out.push_str("</code>");
        } else {
            let escaped = escape(part);
            let pieces: Vec<&str> = escaped.split("**").collect();
            for (j, p) in pieces.iter().enumerate() {
                if j > 0 {
                    out.push_str(if j % 2 == 1 { "<strong>" } else { "</strong>" });
                }
                out.push_str(p);
            }
            // An odd number of `**` leaves the last one open: close it.
            if pieces.len().is_multiple_of(2) {
                out.push_str("</strong>");
            }
        }
    }
    out
}

/// A table row's cells (`| a | b |` → `["a", "b"]`); `\|` stays a `|` inside a cell.
fn cells(line: &str) -> Vec<String> {
    let inner = line.trim().trim_start_matches('|');
    let inner = inner.strip_suffix('|').unwrap_or(inner);
    let mut cells = vec![String::new()];
    let mut chars = inner.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\\' if chars.peek() == Some(&'|') => {
                cells.last_mut().expect("one cell").push('|');
                chars.next();
            }
            '|' => cells.push(String::new()),
            c => cells.last_mut().expect("one cell").push(c),
        }
    }
    cells.into_iter().map(|c| c.trim().to_string()).collect()
}

fn is_separator(line: &str) -> bool {
    let t = line.trim();
    t.starts_with('|') && t.chars().all(|c| matches!(c, '|' | '-' | ':' | ' '))
}

/// `md` as HTML (module docs).
pub fn to_html(md: &str) -> String {
    let lines: Vec<&str> = md.lines().collect();
    let mut out = String::new();
    let mut para: Vec<&str> = Vec::new();
    let flush = |para: &mut Vec<&str>, out: &mut String| {
        if !para.is_empty() {
            let text: Vec<String> = para.iter().map(|l| inline(l.trim())).collect();
            out.push_str(&format!("<p>{}</p>\n", text.join("<br>\n")));
            para.clear();
        }
    };
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        let t = line.trim_start();
        if t.starts_with("```") {
            flush(&mut para, &mut out);
            out.push_str("<pre><code>");
            i += 1;
            while i < lines.len() && !lines[i].trim_start().starts_with("```") {
                out.push_str(&escape(lines[i]));
                out.push('\n');
                i += 1;
            }
            out.push_str("</code></pre>\n");
            i += 1;
            continue;
        }
        if let Some(level) = (1..=6).find(|&n| t.starts_with(&format!("{} ", "#".repeat(n)))) {
            flush(&mut para, &mut out);
            out.push_str(&format!(
                "<h{level}>{}</h{level}>\n",
                inline(t[level..].trim())
            ));
            i += 1;
            continue;
        }
        if t.starts_with('|') && lines.get(i + 1).is_some_and(|l| is_separator(l)) {
            flush(&mut para, &mut out);
            out.push_str("<table>\n<thead><tr>");
            for c in cells(t) {
                out.push_str(&format!("<th>{}</th>", inline(&c)));
            }
            out.push_str("</tr></thead>\n<tbody>\n");
            i += 2;
            while i < lines.len() && lines[i].trim_start().starts_with('|') {
                out.push_str("<tr>");
                for c in cells(lines[i]) {
                    out.push_str(&format!("<td>{}</td>", inline(&c)));
                }
                out.push_str("</tr>\n");
                i += 1;
            }
            out.push_str("</tbody>\n</table>\n");
            continue;
        }
        if t.starts_with("- ") || t.starts_with("* ") {
            flush(&mut para, &mut out);
            out.push_str("<ul>\n");
            while i < lines.len() {
                let l = lines[i].trim_start();
                if !(l.starts_with("- ") || l.starts_with("* ")) {
                    break;
                }
                out.push_str(&format!("<li>{}</li>\n", inline(l[2..].trim())));
                i += 1;
            }
            out.push_str("</ul>\n");
            continue;
        }
        if t.is_empty() {
            flush(&mut para, &mut out);
        } else {
            para.push(line);
        }
        i += 1;
    }
    flush(&mut para, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_report_s_tables_headings_and_lists_become_html_and_text_is_escaped() {
        let md = "# Run — <x>\n\nPreset `quick`, **bold** & more.\nsecond line\n\n\
                  | a | b |\n|---|---|\n| 1 < 2 | `x\\|y` |\n\n- one\n- two\n";
        let html = to_html(md);
        assert!(html.contains("<h1>Run — &lt;x&gt;</h1>"), "{html}");
        assert!(
            html.contains("<p>Preset <code>quick</code>, <strong>bold</strong> &amp; more.<br>\nsecond line</p>"),
            "{html}"
        );
        assert!(
            html.contains("<thead><tr><th>a</th><th>b</th></tr></thead>"),
            "{html}"
        );
        assert!(
            html.contains("<tr><td>1 &lt; 2</td><td><code>x|y</code></td></tr>"),
            "{html}"
        );
        assert!(
            html.contains("<ul>\n<li>one</li>\n<li>two</li>\n</ul>"),
            "{html}"
        );
        assert!(!html.contains("<x>"));
    }

    #[test]
    fn unbalanced_markup_is_closed_and_never_leaks_a_tag() {
        let html = to_html("a `b and **c\n");
        assert_eq!(
            html.matches("<code>").count(),
            html.matches("</code>").count()
        );
        assert_eq!(
            html.matches("<strong>").count(),
            html.matches("</strong>").count()
        );
        let html = to_html("x **y\n");
        assert_eq!(
            html.matches("<strong>").count(),
            html.matches("</strong>").count()
        );
    }
}
