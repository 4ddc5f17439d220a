//! Tokens of the legacy format.
//!
//! The original reads tokens with C's `fscanf("%s")`: a token is a maximal run of non-whitespace
//! characters. Numbers are read with `%f`/`%d`, which stop at the first character that cannot
//! continue a number, so `shininess 20}` works there. This port splits `{ } [ ]` off their
//! neighbours instead (a strict superset on every sample file) and requires a number token to be
//! a number as a whole, so `20abc` is an error rather than a silent misread.

/// A location in the source text: a byte range plus the 1-based line and column (in characters)
/// of its start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span {
    /// Byte offset of the first byte.
    pub start: usize,
    /// Byte offset one past the last byte.
    pub end: usize,
    /// 1-based line number.
    pub line: u32,
    /// 1-based column, counted in characters (a tab counts as one).
    pub col: u32,
}

impl Span {
    /// A span covering `self` through `other`.
    pub fn to(self, other: Span) -> Span {
        Span {
            end: other.end.max(self.end),
            ..self
        }
    }
}

/// One token with its location.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Token<'a> {
    /// The token's text (never empty).
    pub text: &'a str,
    /// Where it is.
    pub span: Span,
}

/// C's `isspace` in the "C" locale: space, tab, LF, vertical tab, form feed, CR.
fn is_space(c: char) -> bool {
    matches!(c, ' ' | '\t' | '\n' | '\x0b' | '\x0c' | '\r')
}

fn is_bracket(c: char) -> bool {
    matches!(c, '{' | '}' | '[' | ']')
}

/// A lazy tokenizer with one token of look-ahead. It never allocates per token, so a huge input
/// costs no more memory than its text.
#[derive(Debug, Clone)]
pub struct Lexer<'a> {
    src: &'a str,
    pos: usize,
    line: u32,
    col: u32,
    peeked: Option<Option<Token<'a>>>,
    /// Span of the last token returned by [`Lexer::next`] (for "end of file after …" errors).
    last: Span,
}

impl<'a> Lexer<'a> {
    /// A lexer over `src`.
    pub fn new(src: &'a str) -> Self {
        Lexer {
            src,
            pos: 0,
            line: 1,
            col: 1,
            peeked: None,
            last: Span {
                line: 1,
                col: 1,
                ..Span::default()
            },
        }
    }

    /// The whole source text.
    pub fn source(&self) -> &'a str {
        self.src
    }

    /// The span of the last token consumed.
    pub fn last_span(&self) -> Span {
        self.last
    }

    /// The next token without consuming it.
    pub fn peek(&mut self) -> Option<Token<'a>> {
        if self.peeked.is_none() {
            let t = self.scan();
            self.peeked = Some(t);
        }
        self.peeked.flatten()
    }

    /// Consumes and returns the next token.
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> Option<Token<'a>> {
        let t = match self.peeked.take() {
            Some(t) => t,
            None => self.scan(),
        };
        if let Some(t) = t {
            self.last = t.span;
        }
        t
    }

    fn bump(&mut self, c: char) {
        self.pos += c.len_utf8();
        if c == '\n' {
            self.line = self.line.saturating_add(1);
            self.col = 1;
        } else {
            self.col = self.col.saturating_add(1);
        }
    }

    fn scan(&mut self) -> Option<Token<'a>> {
        let rest = &self.src[self.pos..];
        let mut chars = rest.chars();
        // Skip whitespace.
        loop {
            let c = chars.clone().next()?;
            if is_space(c) {
                chars.next();
                self.bump(c);
            } else {
                break;
            }
        }
        let start = self.pos;
        let (line, col) = (self.line, self.col);
        let first = self.src[self.pos..].chars().next()?;
        if is_bracket(first) {
            self.bump(first);
        } else {
            while let Some(c) = self.src[self.pos..].chars().next() {
                if is_space(c) || is_bracket(c) {
                    break;
                }
                self.bump(c);
            }
        }
        Some(Token {
            text: &self.src[start..self.pos],
            span: Span {
                start,
                end: self.pos,
                line,
                col,
            },
        })
    }
}

/// Parses a token as a C `%f` float, as a whole: optional sign, digits with an optional decimal
/// point (at least one digit), optional exponent. `inf`, `nan` and hexadecimal floats, which C
/// also accepts, are refused: no scene means them.
pub fn parse_float(text: &str) -> Option<f32> {
    let b = text.as_bytes();
    let mut i = 0;
    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
        i += 1;
    }
    let mut digits = 0;
    while i < b.len() && b[i].is_ascii_digit() {
        i += 1;
        digits += 1;
    }
    if i < b.len() && b[i] == b'.' {
        i += 1;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
            digits += 1;
        }
    }
    if digits == 0 {
        return None;
    }
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        i += 1;
        if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
            i += 1;
        }
        let exp_start = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        if i == exp_start {
            return None;
        }
    }
    if i != b.len() {
        return None;
    }
    // Rust's parser is correctly rounded and accepts this whole grammar ("1.", ".5", "1e5").
    // A leading '+' is accepted by Rust too. Overflow gives ±inf, which we refuse.
    let v: f32 = text.parse().ok()?;
    v.is_finite().then_some(v)
}

/// Parses a token as a C `%d` integer, as a whole: optional sign and decimal digits.
pub fn parse_int(text: &str) -> Option<i64> {
    let digits = text.strip_prefix(['+', '-']).unwrap_or(text);
    if digits.is_empty() || digits.len() > 18 || !digits.bytes().all(|c| c.is_ascii_digit()) {
        return None;
    }
    text.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texts(src: &str) -> Vec<(String, u32, u32)> {
        let mut lx = Lexer::new(src);
        let mut out = Vec::new();
        while let Some(t) = lx.next() {
            out.push((t.text.to_string(), t.span.line, t.span.col));
        }
        out
    }

    #[test]
    fn splits_brackets_and_tracks_lines_with_crlf() {
        let toks = texts("Material {diffuseColor 1 0 0\r\n\tshininess 20}\r\n[ 1 2 3]");
        let words: Vec<&str> = toks.iter().map(|t| t.0.as_str()).collect();
        assert_eq!(
            words,
            [
                "Material",
                "{",
                "diffuseColor",
                "1",
                "0",
                "0",
                "shininess",
                "20",
                "}",
                "[",
                "1",
                "2",
                "3",
                "]"
            ]
        );
        assert_eq!((toks[6].1, toks[6].2), (2, 2)); // shininess after a tab
        assert_eq!((toks[8].1, toks[8].2), (2, 14)); // the brace split off "20}"
        assert_eq!((toks[9].1, toks[9].2), (3, 1));
    }

    #[test]
    fn c_style_floats() {
        for (s, v) in [
            ("-1", -1.0),
            (".5", 0.5),
            ("-.16", -0.16),
            ("1e-3", 1e-3),
            ("0.000000", 0.0),
            ("1.", 1.0),
            ("+2E2", 200.0),
        ] {
            assert_eq!(parse_float(s), Some(v), "{s}");
        }
        for s in [
            "", "-", ".", "e3", "1e", "1.2.3", "inf", "nan", "0x10", "20abc", "1e99", "1,5",
        ] {
            assert_eq!(parse_float(s), None, "{s}");
        }
        assert_eq!(parse_int("-12"), Some(-12));
        assert_eq!(parse_int("200.0"), None);
        assert_eq!(parse_int("99999999999999999999"), None);
    }
}
