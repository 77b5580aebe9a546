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
    let mut rows = Vec::new();
    let mut row = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut line = 1;
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
                rows.push(std::mem::take(&mut row));
                line += 1;
                any = false;
            }
            _ => cur.push(c),
        }
    }
    if quoted {
        return Err(format!("line {line}: unterminated quoted field"));
    }
    if any {
        row.push(cur);
        rows.push(row);
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
        assert!(parse("\"open").unwrap_err().contains("line 1"));
    }
}
