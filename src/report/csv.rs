//! Comma-separated values as `results.csv` and `compare.csv` use them
//! (RFC 4180): a field with a comma, a quote or a line break is quoted,
//! quotes doubled; lines end with `\n`.

/// One field, quoted if needed.
pub fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

/// One line of fields, ending with `\n`.
pub fn line<S: AsRef<str>>(fields: &[S]) -> String {
    let mut s = fields.iter().map(|f| field(f.as_ref())).collect::<Vec<_>>().join(",");
    s.push('\n');
    s
}

/// Parse CSV text into rows of fields; the error names the line.
pub fn parse(text: &str) -> Result<Vec<Vec<String>>, String> {
    Ok(parse_lines(text)?.into_iter().map(|(_, r)| r).collect())
}

/// Parse CSV text into rows of fields, each with the 1-based line it
/// starts on; the error names the line. Blank lines (no field at all) are
/// rows of one empty field, as RFC 4180 has it; readers decide.
pub fn parse_lines(text: &str) -> Result<Vec<(usize, Vec<String>)>, String> {
    let mut rows = Vec::new();
    let mut row = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut line = 1;
    let mut start = 1;
    let mut chars = text.chars().peekable();
    let mut any = false;
    while let Some(c) = chars.next() {
        any = true;
        if quoted {
            match c {
                '"' if chars.peek() == Some(&'"') => {
                    chars.next();
                    cur.push('"');
                }
                '"' => quoted = false,
                '\n' => {
                    line += 1;
                    cur.push(c);
                }
                _ => cur.push(c),
            }
            continue;
        }
        match c {
            '"' if cur.is_empty() => quoted = true,
            ',' => row.push(std::mem::take(&mut cur)),
            '\r' if chars.peek() == Some(&'\n') => {}
            '\n' => {
                row.push(std::mem::take(&mut cur));
                rows.push((start, std::mem::take(&mut row)));
                line += 1;
                start = line;
                any = false;
            }
            _ => cur.push(c),
        }
    }
    if quoted {
        return Err(format!("{start}: unterminated quoted field (a `\"` without its closing quote)"));
    }
    if any {
        row.push(cur);
        rows.push((start, row));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_round_trip() {
        let fields = ["plain", "a,b", "say \"hi\"", "", "two\nlines"];
        let text = line(&fields) + &line(&["x", "y", "z", "w", "v"]);
        let rows = parse(&text).unwrap();
        assert_eq!(rows[0], fields);
        assert_eq!(rows.len(), 2);
        assert_eq!(parse("a,b").unwrap(), vec![vec!["a", "b"]]);
        assert!(parse("\"open").unwrap_err().starts_with("1: unterminated"));
        let lines = parse_lines("a,b\n\"x\ny\",2\nc,3\n").unwrap();
        assert_eq!(lines.iter().map(|r| r.0).collect::<Vec<_>>(), [1, 2, 4]);
    }
}
