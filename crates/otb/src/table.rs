//! A plain text table: the paper's cells beside ours, printed and written as CSV.

use std::fmt;

/// A rectangular table of strings with a title and a header row.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Title printed above the table.
    pub title: String,
    /// Column headers.
    pub header: Vec<String>,
    /// Rows; each has `header.len()` cells.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// An empty table with the given title and header.
    pub fn new(title: impl Into<String>, header: &[&str]) -> Self {
        Self {
            title: title.into(),
            header: header.iter().map(|s| s.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row.
    ///
    /// # Panics
    /// When the row does not have one cell per column (a programming error).
    pub fn push(&mut self, row: Vec<String>) {
        assert_eq!(row.len(), self.header.len(), "row width != header width");
        self.rows.push(row);
    }

    /// The table as CSV (RFC 4180 quoting where a cell needs it), the
    /// header as keys without spaces ([`crate::write::csv_key`]: `paper
    /// mean` is `paper_mean`); the cells are the printed ones.
    pub fn to_csv(&self) -> String {
        // flexible: the fields are public, so a row may have another width
        let mut out = csv::WriterBuilder::new()
            .flexible(true)
            .from_writer(Vec::new());
        let keys = self.header.iter().map(|h| crate::write::csv_key(h));
        out.write_record(keys)
            .and_then(|()| self.rows.iter().try_for_each(|r| out.write_record(r)))
            .unwrap_or_else(|e| panic!("writing CSV to memory: {e}"));
        crate::write::into_text(out)
    }

    /// The table as a Markdown (GitHub) table, the title as a bold line
    /// above it when it is not empty.
    pub fn to_markdown(&self) -> String {
        let row = |cells: &[String]| format!("| {} |\n", cells.join(" | ").replace('\n', " "));
        let mut out = String::new();
        if !self.title.is_empty() {
            out.push_str(&format!("**{}**\n\n", self.title));
        }
        out.push_str(&row(&self.header));
        let rule: Vec<String> = (0..self.header.len())
            .map(|i| if i == 0 { "---".into() } else { "---:".into() })
            .collect();
        out.push_str(&row(&rule));
        for r in &self.rows {
            out.push_str(&row(r));
        }
        out
    }
}

impl fmt::Display for Table {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ncol = self.header.len();
        let mut width = vec![0usize; ncol];
        for row in std::iter::once(&self.header).chain(&self.rows) {
            for (w, c) in width.iter_mut().zip(row) {
                *w = (*w).max(c.chars().count());
            }
        }
        writeln!(f, "{}", self.title)?;
        let line = |f: &mut fmt::Formatter<'_>, row: &[String]| -> fmt::Result {
            let cells: Vec<String> = row
                .iter()
                .zip(&width)
                .enumerate()
                .map(|(i, (c, w))| {
                    if i == 0 {
                        format!("{c:<w$}")
                    } else {
                        format!("{c:>w$}")
                    }
                })
                .collect();
            writeln!(f, "  {}", cells.join("  "))
        };
        line(f, &self.header)?;
        let total: usize = width.iter().sum::<usize>() + 2 * ncol.saturating_sub(1);
        writeln!(f, "  {}", "-".repeat(total))?;
        for row in &self.rows {
            line(f, row)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quotes_cells_that_need_it() {
        let mut t = Table::new("t", &["a", "b"]);
        t.push(vec!["x,y".into(), "1".into()]);
        assert_eq!(t.to_csv(), "a,b\n\"x,y\",1\n");
    }

    #[test]
    fn markdown_has_a_rule_under_the_header() {
        let mut t = Table::new("T", &["a", "b"]);
        t.push(vec!["x".into(), "1".into()]);
        assert_eq!(
            t.to_markdown(),
            "**T**\n\n| a | b |\n| --- | ---: |\n| x | 1 |\n"
        );
    }

    #[test]
    fn display_aligns_columns() {
        let mut t = Table::new("T", &["name", "v"]);
        t.push(vec!["long name".into(), "1.5".into()]);
        let s = t.to_string();
        assert!(s.contains("  name         v"), "{s}");
        assert!(s.contains("  long name  1.5"), "{s}");
    }
}
