//! Finding where a JSON path points in the source text, so that errors found after parsing
//! (semantic checks) can name a line and column like syntax errors do.

use std::fmt;

/// One step of a path into a JSON document.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PathSegment {
    /// An object member.
    Key(String),
    /// An array element.
    Index(usize),
}

/// A path into a JSON document, written like `objects[3].sphere.radius`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct JsonPath(pub Vec<PathSegment>);

impl JsonPath {
    /// The empty path (the document root).
    pub fn root() -> Self {
        JsonPath(Vec::new())
    }

    /// This path extended by a member key.
    pub fn key(&self, key: &str) -> Self {
        let mut p = self.clone();
        p.0.push(PathSegment::Key(key.to_string()));
        p
    }

    /// This path extended by an array index.
    pub fn index(&self, index: usize) -> Self {
        let mut p = self.clone();
        p.0.push(PathSegment::Index(index));
        p
    }

    /// Parses the path format printed by `serde_path_to_error` (`a.b[2].c`). Keys containing
    /// dots or brackets are not representable there either; they are kept as written.
    pub fn parse(text: &str) -> Self {
        let mut segs = Vec::new();
        if text == "." || text.is_empty() {
            return JsonPath(segs);
        }
        for part in text.split('.') {
            let mut rest = part;
            if let Some(open) = rest.find('[') {
                if open > 0 {
                    segs.push(PathSegment::Key(rest[..open].to_string()));
                }
                rest = &rest[open..];
                while let Some(stripped) = rest.strip_prefix('[') {
                    let Some(close) = stripped.find(']') else {
                        break;
                    };
                    match stripped[..close].parse() {
                        Ok(i) => segs.push(PathSegment::Index(i)),
                        Err(_) => segs.push(PathSegment::Key(stripped[..close].to_string())),
                    }
                    rest = &stripped[close + 1..];
                }
            } else if !rest.is_empty() && rest != "?" {
                // `?` is serde_path_to_error's marker for a position it could not name.
                segs.push(PathSegment::Key(rest.to_string()));
            }
        }
        JsonPath(segs)
    }
}

impl fmt::Display for JsonPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_empty() {
            return write!(f, "(root)");
        }
        for (i, seg) in self.0.iter().enumerate() {
            match seg {
                PathSegment::Key(k) => {
                    let plain = !k.is_empty()
                        && k.chars()
                            .all(|c| c.is_alphanumeric() || c == '_' || c == '$' || c == '-');
                    match (plain, i) {
                        (true, 0) => write!(f, "{k}")?,
                        (true, _) => write!(f, ".{k}")?,
                        (false, _) => write!(f, "[{k:?}]")?,
                    }
                }
                PathSegment::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// A 1-based line and column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineCol {
    /// Line number, starting at 1.
    pub line: usize,
    /// Column number in characters, starting at 1.
    pub column: usize,
}

/// Where the value at `path` starts in `text`, or the deepest existing ancestor's value when
/// the path leads to a member that is absent. `text` must be valid JSON; on malformed text the
/// search stops and returns what it found so far.
pub fn locate(text: &str, path: &JsonPath) -> Option<LineCol> {
    let bytes = text.as_bytes();
    let mut scanner = Scanner {
        bytes,
        pos: 0,
        key: None,
    };
    scanner.skip_ws();
    let mut found = scanner.pos;
    for seg in &path.0 {
        match scanner.descend(seg) {
            Some(pos) => found = pos,
            None => break,
        }
    }
    Some(line_col(text, found))
}

/// Byte ranges (start, end exclusive) of the value a path leads to, and of its key.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Spans {
    /// The member name (with its quotes) when the path ends at an object member.
    pub key: Option<(usize, usize)>,
    /// The value.
    pub value: (usize, usize),
    /// The first member name (with its quotes) when the value is a non-empty object.
    pub first_key: Option<(usize, usize)>,
}

/// The byte ranges of the value at `path` in `text`, or `None` when the path leads to nothing
/// there (or the text is malformed on the way).
pub fn spans(text: &str, path: &JsonPath) -> Option<Spans> {
    let mut scanner = Scanner {
        bytes: text.as_bytes(),
        pos: 0,
        key: None,
    };
    scanner.skip_ws();
    let mut key = None;
    for seg in &path.0 {
        scanner.descend(seg)?;
        key = match seg {
            PathSegment::Key(_) => scanner.key,
            PathSegment::Index(_) => None,
        };
    }
    let start = scanner.pos;
    let first_key = if scanner.peek() == Some(b'{') {
        let mut inner = Scanner {
            bytes: scanner.bytes,
            pos: start + 1,
            key: None,
        };
        inner.skip_ws();
        let k = inner.pos;
        inner.string().map(|_| (k, inner.pos))
    } else {
        None
    };
    let end = match scanner.peek()? {
        b'"' => scanner.string().map(|_| scanner.pos)?,
        b'{' | b'[' => scanner.skip_value().map(|()| scanner.pos)?,
        _ => {
            while !matches!(
                scanner.peek(),
                None | Some(b',' | b'}' | b']' | b' ' | b'\t' | b'\n' | b'\r')
            ) {
                scanner.pos += 1;
            }
            scanner.pos
        }
    };
    Some(Spans {
        key,
        value: (start, end),
        first_key,
    })
}

/// The line and column of a byte offset.
pub fn line_col(text: &str, offset: usize) -> LineCol {
    let offset = offset.min(text.len());
    let before = &text[..floor_char_boundary(text, offset)];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    LineCol { line, column }
}

fn floor_char_boundary(text: &str, mut i: usize) -> usize {
    while i > 0 && !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

struct Scanner<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// The range of the member name [`Scanner::descend`] last matched.
    key: Option<(usize, usize)>,
}

impl Scanner<'_> {
    fn peek(&self) -> Option<u8> {
        self.bytes.get(self.pos).copied()
    }

    fn skip_ws(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t' | b'\n' | b'\r')) {
            self.pos += 1;
        }
    }

    /// With `pos` at the start of a container value, moves to the start of the child `seg`
    /// and returns its offset.
    fn descend(&mut self, seg: &PathSegment) -> Option<usize> {
        match (self.peek()?, seg) {
            (b'{', PathSegment::Key(key)) => {
                self.pos += 1;
                loop {
                    self.skip_ws();
                    if self.peek()? == b'}' {
                        return None;
                    }
                    let key_start = self.pos;
                    let name = self.string()?;
                    let key_end = self.pos;
                    self.skip_ws();
                    if self.peek()? != b':' {
                        return None;
                    }
                    self.pos += 1;
                    self.skip_ws();
                    if name == *key {
                        self.key = Some((key_start, key_end));
                        return Some(self.pos);
                    }
                    self.skip_value()?;
                    self.skip_ws();
                    if self.peek()? == b',' {
                        self.pos += 1;
                    }
                }
            }
            (b'[', PathSegment::Index(target)) => {
                self.pos += 1;
                let mut i = 0;
                loop {
                    self.skip_ws();
                    if self.peek()? == b']' {
                        return None;
                    }
                    if i == *target {
                        return Some(self.pos);
                    }
                    self.skip_value()?;
                    self.skip_ws();
                    if self.peek()? == b',' {
                        self.pos += 1;
                    }
                    i += 1;
                }
            }
            _ => None,
        }
    }

    /// Reads a string literal and returns its unescaped-enough content (escapes other than
    /// `\"` and `\\` are kept verbatim; keys in scenes are plain).
    fn string(&mut self) -> Option<String> {
        if self.peek()? != b'"' {
            return None;
        }
        self.pos += 1;
        let start = self.pos;
        let mut out = Vec::new();
        while let Some(b) = self.peek() {
            match b {
                b'"' => {
                    self.pos += 1;
                    let _ = start;
                    return String::from_utf8(out).ok();
                }
                b'\\' => {
                    let next = *self.bytes.get(self.pos + 1)?;
                    if next == b'"' || next == b'\\' {
                        out.push(next);
                    } else {
                        out.push(b);
                        out.push(next);
                    }
                    self.pos += 2;
                }
                _ => {
                    out.push(b);
                    self.pos += 1;
                }
            }
        }
        None
    }

    fn skip_value(&mut self) -> Option<()> {
        let mut depth = 0usize;
        loop {
            match self.peek()? {
                b'"' => {
                    self.string()?;
                }
                b'{' | b'[' => {
                    depth += 1;
                    self.pos += 1;
                }
                b'}' | b']' => {
                    if depth == 0 {
                        return Some(());
                    }
                    depth -= 1;
                    self.pos += 1;
                }
                b',' if depth == 0 => return Some(()),
                _ => self.pos += 1,
            }
            if depth == 0
                && matches!(
                    self.bytes.get(self.pos.wrapping_sub(1)),
                    Some(b'}' | b']' | b'"')
                )
            {
                // A container or string just closed at top level: the value is complete.
                return Some(());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_round_trips_through_display_and_parse() {
        let p = JsonPath::root()
            .key("objects")
            .index(3)
            .key("sphere")
            .key("radius");
        assert_eq!(p.to_string(), "objects[3].sphere.radius");
        assert_eq!(JsonPath::parse("objects[3].sphere.radius"), p);
    }

    #[test]
    fn locates_nested_values() {
        let text = "{\n  \"a\": [1, {\"b\": \"x\"}],\n  \"c\": {\n    \"d\": 2.5\n  }\n}";
        let at = |p: &str| locate(text, &JsonPath::parse(p)).unwrap();
        assert_eq!(
            at("c.d"),
            LineCol {
                line: 4,
                column: 10
            }
        );
        assert_eq!(
            at("a[1].b"),
            LineCol {
                line: 2,
                column: 18
            }
        );
        assert_eq!(at("a[0]"), LineCol { line: 2, column: 9 });
        // A missing member points at its parent.
        assert_eq!(at("c.zzz"), LineCol { line: 3, column: 8 });
    }
}
