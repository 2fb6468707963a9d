//! The Markdown document being assembled: headings, paragraphs, tables and images, written
//! once at the end (atomically, so an interrupted run leaves the previous report).

use std::fmt::Write as _;
use std::path::Path;

/// A Markdown document under construction.
#[derive(Default)]
pub struct Report {
    md: String,
}

impl Report {
    /// A heading of `level` (1 = `#`).
    pub fn heading(&mut self, level: usize, text: &str) {
        let _ = writeln!(self.md, "{} {text}\n", "#".repeat(level));
    }

    /// A paragraph (or any block of Markdown), followed by a blank line.
    pub fn para(&mut self, text: &str) {
        let _ = writeln!(self.md, "{}\n", text.trim_end());
    }

    /// A table: a header row and rows of cells (all right-aligned but the first column).
    pub fn table(&mut self, header: &[&str], rows: &[Vec<String>]) {
        let _ = writeln!(self.md, "| {} |", header.join(" | "));
        let align: Vec<&str> = (0..header.len())
            .map(|i| if i == 0 { "---" } else { "---:" })
            .collect();
        let _ = writeln!(self.md, "|{}|", align.join("|"));
        for r in rows {
            let _ = writeln!(self.md, "| {} |", r.join(" | "));
        }
        self.md.push('\n');
    }

    /// An image, by a path relative to the document.
    pub fn image(&mut self, alt: &str, rel: &str) {
        let _ = writeln!(self.md, "![{alt}]({rel})\n");
    }

    /// The document so far.
    pub fn text(&self) -> &str {
        &self.md
    }

    /// Writes the document to `path` atomically.
    pub fn write(&self, path: &Path) -> anyhow::Result<()> {
        // A temporary file beside the target, renamed over it once written.
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
        let mut tmp = tempfile::NamedTempFile::new_in(dir.unwrap_or_else(|| Path::new(".")))?;
        std::io::Write::write_all(&mut tmp, self.md.as_bytes())?;
        tmp.persist(path)?;
        Ok(())
    }
}

/// `x` with `digits` decimals.
pub fn f(x: f64, digits: usize) -> String {
    format!("{x:.digits$}")
}

/// Milliseconds from seconds, with precision that suits the size.
pub fn ms(s: f64) -> String {
    let m = s * 1e3;
    if m >= 100.0 {
        format!("{m:.0} ms")
    } else if m >= 10.0 {
        format!("{m:.1} ms")
    } else {
        format!("{m:.2} ms")
    }
}

/// The median of `v` (the upper one for an even count); 0 when empty.
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}
