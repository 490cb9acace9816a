//! A minimal reader for the comma-separated files vadscope writes (`boxes.csv`,
//! `frame_labels.csv`): a header row naming the columns, then plain fields without quotes.
//! Columns are found by name, so extra columns and other orders are accepted.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use super::SequenceError;

/// A parsed CSV file: its header and data rows with their 1-based line numbers.
pub(crate) struct CsvTable {
    path: PathBuf,
    header: Vec<String>,
    rows: Vec<(usize, Vec<String>)>,
}

impl CsvTable {
    /// Parses `text`; the header must contain every column in `required`. Blank lines are
    /// skipped; a row with a different field count than the header is an error.
    pub(crate) fn parse(path: &Path, text: &str, required: &[&str]) -> Result<Self, SequenceError> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, line)| !line.trim().is_empty());
        let Some((_, header_line)) = lines.next() else {
            return Err(SequenceError::format(
                path,
                format!("empty file: expected a header `{}`", required.join(",")),
            ));
        };
        let header: Vec<String> = split_fields(header_line);
        if let Some(missing) = required
            .iter()
            .find(|name| !header.iter().any(|h| h == *name))
        {
            return Err(SequenceError::Line {
                path: path.to_path_buf(),
                line: 1,
                problem: format!(
                    "header lacks column '{missing}' (expected `{}`)",
                    required.join(",")
                ),
            });
        }
        let mut rows = Vec::new();
        for (index, line) in lines {
            let fields = split_fields(line);
            if fields.len() != header.len() {
                return Err(SequenceError::Line {
                    path: path.to_path_buf(),
                    line: index + 1,
                    problem: format!(
                        "row has {} fields, the header has {}",
                        fields.len(),
                        header.len()
                    ),
                });
            }
            rows.push((index + 1, fields));
        }
        Ok(Self {
            path: path.to_path_buf(),
            header,
            rows,
        })
    }

    /// Reads and parses a CSV file.
    pub(crate) fn read(path: &Path, required: &[&str]) -> Result<Self, SequenceError> {
        let text = std::fs::read_to_string(path).map_err(|e| SequenceError::io(path, e))?;
        Self::parse(path, &text, required)
    }

    /// The position of a column, if the header has it.
    pub(crate) fn column(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// The data rows.
    pub(crate) fn rows(&self) -> impl Iterator<Item = CsvRow<'_>> {
        self.rows.iter().map(|(line, fields)| CsvRow {
            path: &self.path,
            line: *line,
            fields,
        })
    }
}

fn split_fields(line: &str) -> Vec<String> {
    line.split(',').map(|f| f.trim().to_string()).collect()
}

/// One data row of a [`CsvTable`].
pub(crate) struct CsvRow<'a> {
    path: &'a Path,
    line: usize,
    fields: &'a [String],
}

impl CsvRow<'_> {
    /// Parses the field in column `index` (named `name` for the error message).
    pub(crate) fn parse<T: FromStr>(&self, index: usize, name: &str) -> Result<T, SequenceError> {
        let field = self
            .fields
            .get(index)
            .map(String::as_str)
            .unwrap_or_default();
        field
            .parse()
            .map_err(|_| self.error(format!("column '{name}': cannot read {field:?}")))
    }

    /// Parses a 0/1 (or true/false) flag in column `index`.
    pub(crate) fn flag(&self, index: usize, name: &str) -> Result<bool, SequenceError> {
        match self
            .fields
            .get(index)
            .map(String::as_str)
            .unwrap_or_default()
        {
            "1" | "true" | "True" => Ok(true),
            "0" | "false" | "False" => Ok(false),
            other => Err(self.error(format!("column '{name}': expected 0 or 1, found {other:?}"))),
        }
    }

    /// An error about this row.
    pub(crate) fn error(&self, problem: String) -> SequenceError {
        SequenceError::Line {
            path: self.path.to_path_buf(),
            line: self.line,
            problem,
        }
    }
}
