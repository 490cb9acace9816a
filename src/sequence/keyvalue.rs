//! AnoVox ACTION / ANOMALY files: one `key ; value` pair per line, no header, values are
//! Python reprs (numbers, bools, tuples, lists).

use std::path::Path;

use super::py_literal::PyValue;
use super::{KeyValues, SequenceError};

/// The separator AnoVox writes between key and value.
const SEPARATOR: &str = " ; ";

/// Parses `key ; value` text. Blank lines are skipped; a line without `;` or with an empty
/// key is an error naming the file and line. Values keep any further `;`.
pub fn parse_key_values(path: &Path, text: &str) -> Result<KeyValues, SequenceError> {
    let mut values = KeyValues::default();
    for (number, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let line_error = |problem: &str| SequenceError::Line {
            path: path.to_path_buf(),
            line: number + 1,
            problem: problem.to_string(),
        };
        let (key, value) = line
            .split_once(';')
            .ok_or_else(|| line_error("expected `key ; value`, found no ';'"))?;
        let key = key.trim();
        if key.is_empty() {
            return Err(line_error("empty key before ';'"));
        }
        values.push(key, value.trim());
    }
    Ok(values)
}

/// Reads an ACTION / ANOMALY file.
pub fn read_key_values(path: &Path) -> Result<KeyValues, SequenceError> {
    let text = std::fs::read_to_string(path).map_err(|e| SequenceError::io(path, e))?;
    parse_key_values(path, &text)
}

/// Formats pairs as `key ; value` lines. Keys must not contain `;` or line breaks and values
/// must not contain line breaks, otherwise the file could not be read back.
pub fn format_key_values(path: &Path, values: &KeyValues) -> Result<String, SequenceError> {
    let mut text = String::new();
    for (key, value) in &values.entries {
        if key.trim().is_empty() || key.contains([';', '\n', '\r']) {
            return Err(SequenceError::format(
                path,
                format!("key {key:?} is empty or contains ';' or a line break"),
            ));
        }
        if value.contains(['\n', '\r']) {
            return Err(SequenceError::format(
                path,
                format!("value of key {key:?} contains a line break"),
            ));
        }
        text.push_str(key.trim());
        text.push_str(SEPARATOR);
        text.push_str(value.trim());
        text.push('\n');
    }
    Ok(text)
}

/// Writes an ACTION / ANOMALY file.
pub fn write_key_values(path: &Path, values: &KeyValues) -> Result<(), SequenceError> {
    let text = format_key_values(path, values)?;
    std::fs::write(path, text).map_err(|e| SequenceError::io(path, e))
}

impl KeyValues {
    /// The value of `key` parsed as a Python literal (tuple, list, number, bool, string).
    pub fn get_literal(&self, key: &str) -> Option<PyValue> {
        PyValue::parse(self.get(key)?).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_anovox_lines_with_python_values() {
        let text = "frame_id ; 5720\nspeed ; 31.5\nreverse ; False\n\n\
                    center_of_mass ; (0.1, 0.0, -0.2)\ncamera transformation matrix ; [[1.0, 0.0], [0.0, 1.0]]\n";
        let values = parse_key_values(Path::new("ACTION_5720.csv"), text).expect("valid");
        assert_eq!(values.entries.len(), 5);
        assert_eq!(values.speed_kmh(), Some(31.5));
        assert_eq!(values.get_f64("reverse"), Some(0.0));
        assert_eq!(
            values
                .get_literal("center_of_mass")
                .and_then(|v| v.as_numbers()),
            Some(vec![0.1, 0.0, -0.2])
        );
        assert_eq!(
            values.get("camera transformation matrix"),
            Some("[[1.0, 0.0], [0.0, 1.0]]")
        );
    }

    #[test]
    fn bad_lines_name_file_and_line() {
        let error = parse_key_values(Path::new("ANOMALY_3.csv"), "brake ; 1.0\nno separator\n")
            .expect_err("line 2 is bad");
        let text = error.to_string();
        assert!(text.contains("ANOMALY_3.csv:2"), "{text}");
        assert!(parse_key_values(Path::new("a.csv"), " ; 3").is_err());
    }

    #[test]
    fn format_rejects_unreadable_keys_and_values() {
        let mut values = KeyValues::default();
        values.push("a;b", 1);
        assert!(format_key_values(Path::new("x.csv"), &values).is_err());
        let mut values = KeyValues::default();
        values.push("a", "1\n2");
        assert!(format_key_values(Path::new("x.csv"), &values).is_err());
    }
}
