//! A parser for the small subset of Python literals found in scenario files: the header
//! dictionary of `.npy` files (`{'descr': '<f4', 'fortran_order': False, 'shape': (4, 5, 2), }`)
//! and the tuple/list/number values of AnoVox ACTION/ANOMALY CSVs.

/// A parsed Python literal.
#[derive(Debug, Clone, PartialEq)]
pub enum PyValue {
    /// A quoted string (no escape sequences are interpreted beyond `\'` and `\"`).
    Str(String),
    /// `True` or `False`.
    Bool(bool),
    /// An integer or float literal.
    Number(f64),
    /// `None`.
    None,
    /// A tuple `( ... )` or list `[ ... ]`.
    Sequence(Vec<PyValue>),
    /// A dict `{ key: value, ... }` with string keys, in source order.
    Dict(Vec<(String, PyValue)>),
}

impl PyValue {
    /// Parses a complete literal; trailing text other than whitespace is an error.
    pub fn parse(text: &str) -> Result<PyValue, String> {
        let mut parser = Parser {
            bytes: text.as_bytes(),
            pos: 0,
        };
        let value = parser.value(0)?;
        parser.skip_space();
        if parser.pos != parser.bytes.len() {
            return Err(format!(
                "unexpected text after the literal at byte {}",
                parser.pos
            ));
        }
        Ok(value)
    }

    /// The value of `key` when this is a dict.
    pub fn get(&self, key: &str) -> Option<&PyValue> {
        match self {
            PyValue::Dict(entries) => entries.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }

    /// Every element as a number, when this is a tuple or list of numbers.
    pub fn as_numbers(&self) -> Option<Vec<f64>> {
        match self {
            PyValue::Sequence(items) => items
                .iter()
                .map(|item| match item {
                    PyValue::Number(n) => Some(*n),
                    _ => None,
                })
                .collect(),
            _ => None,
        }
    }
}

/// Nesting deeper than this is rejected, so hostile input cannot overflow the stack.
const MAX_DEPTH: usize = 32;

struct Parser<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Parser<'_> {
    fn skip_space(&mut self) {
        while self
            .bytes
            .get(self.pos)
            .is_some_and(u8::is_ascii_whitespace)
        {
            self.pos += 1;
        }
    }

    fn peek(&mut self) -> Option<u8> {
        self.skip_space();
        self.bytes.get(self.pos).copied()
    }

    fn value(&mut self, depth: usize) -> Result<PyValue, String> {
        if depth > MAX_DEPTH {
            return Err(format!("literal nested deeper than {MAX_DEPTH} levels"));
        }
        match self.peek() {
            None => Err("literal ends too early".to_string()),
            Some(b'\'' | b'"') => self.string().map(PyValue::Str),
            Some(b'(') => self.sequence(b')', depth).map(PyValue::Sequence),
            Some(b'[') => self.sequence(b']', depth).map(PyValue::Sequence),
            Some(b'{') => self.dict(depth),
            Some(_) => self.word(),
        }
    }

    fn string(&mut self) -> Result<String, String> {
        let quote = self.bytes[self.pos];
        let start = self.pos;
        self.pos += 1;
        let mut text = Vec::new();
        while let Some(&byte) = self.bytes.get(self.pos) {
            self.pos += 1;
            match byte {
                b'\\' => {
                    if let Some(&escaped) = self.bytes.get(self.pos) {
                        text.push(escaped);
                        self.pos += 1;
                    }
                }
                b if b == quote => {
                    return String::from_utf8(text)
                        .map_err(|_| format!("string at byte {start} is not UTF-8"));
                }
                b => text.push(b),
            }
        }
        Err(format!("string starting at byte {start} is not closed"))
    }

    fn sequence(&mut self, close: u8, depth: usize) -> Result<Vec<PyValue>, String> {
        self.pos += 1;
        let mut items = Vec::new();
        loop {
            if self.peek() == Some(close) {
                self.pos += 1;
                return Ok(items);
            }
            items.push(self.value(depth + 1)?);
            match self.peek() {
                Some(b',') => self.pos += 1,
                Some(c) if c == close => {}
                _ => {
                    return Err(format!(
                        "expected ',' or '{}' at byte {}",
                        close as char, self.pos
                    ));
                }
            }
        }
    }

    fn dict(&mut self, depth: usize) -> Result<PyValue, String> {
        self.pos += 1;
        let mut entries = Vec::new();
        loop {
            match self.peek() {
                Some(b'}') => {
                    self.pos += 1;
                    return Ok(PyValue::Dict(entries));
                }
                Some(b'\'' | b'"') => {}
                _ => return Err(format!("expected a string key at byte {}", self.pos)),
            }
            let key = self.string()?;
            if self.peek() != Some(b':') {
                return Err(format!(
                    "expected ':' after key '{key}' at byte {}",
                    self.pos
                ));
            }
            self.pos += 1;
            let value = self.value(depth + 1)?;
            entries.push((key, value));
            match self.peek() {
                Some(b',') => self.pos += 1,
                Some(b'}') => {}
                _ => return Err(format!("expected ',' or '}}' at byte {}", self.pos)),
            }
        }
    }

    fn word(&mut self) -> Result<PyValue, String> {
        let start = self.pos;
        while self
            .bytes
            .get(self.pos)
            .is_some_and(|b| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'-' | b'+' | b'_'))
        {
            self.pos += 1;
        }
        let word = std::str::from_utf8(&self.bytes[start..self.pos]).unwrap_or_default();
        match word {
            "" => Err(format!("unexpected character at byte {start}")),
            "True" => Ok(PyValue::Bool(true)),
            "False" => Ok(PyValue::Bool(false)),
            "None" => Ok(PyValue::None),
            number => number
                .parse::<f64>()
                .map(PyValue::Number)
                .map_err(|_| format!("'{number}' at byte {start} is not a literal")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_an_npy_header() {
        let header = "{'descr': '<f4', 'fortran_order': False, 'shape': (4, 5, 2), }   ";
        let value = PyValue::parse(header).expect("valid header");
        assert_eq!(value.get("descr"), Some(&PyValue::Str("<f4".into())));
        assert_eq!(value.get("fortran_order"), Some(&PyValue::Bool(false)));
        assert_eq!(
            value.get("shape").and_then(PyValue::as_numbers),
            Some(vec![4.0, 5.0, 2.0])
        );
    }

    #[test]
    fn parses_nested_lists_and_scalars() {
        let value = PyValue::parse("[[1.0, -2.5e1], (3,), None, \"x\"]").expect("valid");
        let PyValue::Sequence(items) = value else {
            panic!("expected a sequence")
        };
        assert_eq!(items[0].as_numbers(), Some(vec![1.0, -25.0]));
        assert_eq!(items[1].as_numbers(), Some(vec![3.0]));
        assert_eq!(items[2], PyValue::None);
        assert_eq!(items[3], PyValue::Str("x".into()));
    }

    #[test]
    fn rejects_garbage_without_panicking() {
        for bad in [
            "",
            "{",
            "{'a' 1}",
            "{1: 2}",
            "(1, 2",
            "'open",
            "[1 2]",
            "nan?",
            "{'a': 1} x",
        ] {
            assert!(PyValue::parse(bad).is_err(), "{bad:?} should fail");
        }
        let deep = "[".repeat(100) + &"]".repeat(100);
        assert!(PyValue::parse(&deep).is_err());
    }
}
