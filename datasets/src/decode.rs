//! What European and Windows instruments write, read as a user expects: the text encoding of a CSV file
//! (UTF-8 with or without a byte-order mark, UTF-16 with or without one, Windows-1252), its delimiter
//! (comma, semicolon or tab, from the header line) and its numbers (decimal commas, thousands
//! separators), normalised before the one table reader ([`crate::table`]) types the cells. Decoding is
//! `encoding_rs`'s; what is decided here is only *which* encoding and *which* marks, and every decision
//! other than plain UTF-8 with commas and decimal points is reported as a note.
//!
//! The rules, per column of text cells:
//! * a number may group its digits by threes with `.`, `,`, a space (also no-break and narrow
//!   no-break), or `'`, and mark its decimals with `.` or `,`;
//! * a cell is evidence of the column's decimal mark when it can be read only one way: `1,5` or
//!   `0,125` (decimal comma: not three digits after the mark), `1.5`; `1.234,5` or `1,234.5` (both marks:
//!   the last is the decimal one); `1.234.567` (a mark used twice groups);
//! * a cell that could be read two ways (`1,234`, `1.234`) is read with the column's decimal mark, or,
//!   when no cell of the column tells, with the file's convention (decimal commas in a file separated by
//!   semicolons or tabs, decimal points in a comma-separated one);
//! * a column whose cells contradict each other (`1,5` in one row, `2.5` in another) is refused naming
//!   the column and the first row that contradicts the others.

use std::borrow::Cow;

/// How a file's bytes were decoded, when not as plain UTF-8.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextEncoding {
    /// UTF-8 (a leading byte-order mark is dropped).
    Utf8 {
        /// Whether the file began with the UTF-8 byte-order mark.
        bom: bool,
    },
    /// UTF-16, little- or big-endian.
    Utf16 {
        /// Big-endian (else little-endian).
        big_endian: bool,
        /// Whether the file began with a byte-order mark (else the byte order was read from the
        /// zero bytes of its ASCII text).
        bom: bool,
    },
    /// Windows-1252 (the Western-European Windows code page), for a file that is not valid UTF-8.
    Windows1252,
}

impl TextEncoding {
    /// The note a reader prints, or `None` for plain UTF-8.
    pub fn note(self) -> Option<String> {
        match self {
            TextEncoding::Utf8 { bom: false } => None,
            TextEncoding::Utf8 { bom: true } => None,
            TextEncoding::Utf16 { big_endian, bom } => Some(format!(
                "read as UTF-16 ({}-endian{})",
                if big_endian { "big" } else { "little" },
                if bom { "" } else { ", no byte-order mark" }
            )),
            TextEncoding::Windows1252 => Some(
                "not UTF-8: read as Windows-1252 (the Western-European Windows code page, e.g. `µ` as \
                 byte B5); save the file as UTF-8 if that is wrong"
                    .into(),
            ),
        }
    }
}

/// Why a file's bytes are not text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NotText {
    /// What is wrong and what to change.
    pub message: String,
}

/// Decodes a CSV file's bytes: a byte-order mark decides (UTF-8, UTF-16 LE/BE); without one, ASCII text
/// with every other byte zero is UTF-16 of that byte order, valid UTF-8 is UTF-8, anything else is read
/// as Windows-1252.
///
/// ```
/// use millcomp_datasets::decode::{decode_text, TextEncoding};
/// let plain = "t_s,y_um\n0,1.5\n";
/// let mut utf16: Vec<u8> = vec![0xFF, 0xFE];
/// utf16.extend(plain.encode_utf16().flat_map(|u| u.to_le_bytes()));
/// let (text, enc) = decode_text(&utf16).unwrap();
/// assert_eq!((text.as_ref(), enc), (plain, TextEncoding::Utf16 { big_endian: false, bom: true }));
/// // `y_µm` written by a Windows program: µ is byte B5
/// let (text, enc) = decode_text(b"t_s,y_\xB5m\n0,1\n").unwrap();
/// assert_eq!((text.as_ref(), enc), ("t_s,y_µm\n0,1\n", TextEncoding::Windows1252));
/// ```
///
/// # Errors
/// [`NotText`] for a UTF-16 file that is not valid UTF-16, or bytes with zeros that are not UTF-16
/// (a binary file: a spreadsheet, an archive).
pub fn decode_text(bytes: &[u8]) -> Result<(Cow<'_, str>, TextEncoding), NotText> {
    if let Some((enc, bom_len)) = encoding_rs::Encoding::for_bom(bytes) {
        let body = &bytes[bom_len..];
        let (kind, name) = if enc == encoding_rs::UTF_8 {
            (TextEncoding::Utf8 { bom: true }, "UTF-8")
        } else {
            let big_endian = enc == encoding_rs::UTF_16BE;
            (
                TextEncoding::Utf16 {
                    big_endian,
                    bom: true,
                },
                if big_endian { "UTF-16BE" } else { "UTF-16LE" },
            )
        };
        return enc
            .decode_without_bom_handling_and_without_replacement(body)
            .map(|t| (t, kind))
            .ok_or_else(|| NotText {
                message: format!(
                    "the file begins with a {name} byte-order mark but is not valid {name}: save it again \
                     as UTF-8 CSV"
                ),
            });
    }
    if bytes.contains(&0) {
        return match utf16_without_bom(bytes) {
            Some(big_endian) => {
                let enc = if big_endian {
                    encoding_rs::UTF_16BE
                } else {
                    encoding_rs::UTF_16LE
                };
                enc.decode_without_bom_handling_and_without_replacement(bytes)
                    .map(|t| {
                        (
                            t,
                            TextEncoding::Utf16 {
                                big_endian,
                                bom: false,
                            },
                        )
                    })
                    .ok_or_else(|| NotText {
                        message: "looks like UTF-16 without a byte-order mark but is not valid UTF-16: \
                                  save it as UTF-8 CSV"
                            .into(),
                    })
            }
            None => Err(NotText {
                message: "holds zero bytes: not a text file (a spreadsheet or an archive?); export it as \
                          CSV (UTF-8)"
                    .into(),
            }),
        };
    }
    match std::str::from_utf8(bytes) {
        Ok(t) => Ok((Cow::Borrowed(t), TextEncoding::Utf8 { bom: false })),
        Err(_) => {
            let (t, _) = encoding_rs::WINDOWS_1252.decode_without_bom_handling(bytes);
            Ok((t, TextEncoding::Windows1252))
        }
    }
}

/// The byte order of UTF-16 text without a byte-order mark, told by where the zero bytes of its ASCII
/// characters fall (the high byte of `t` is 0): `Some(true)` big-endian, `Some(false)` little-endian,
/// `None` when the zeros do not fall on one side.
fn utf16_without_bom(bytes: &[u8]) -> Option<bool> {
    let head = &bytes[..bytes.len().min(4096) & !1];
    if head.len() < 4 {
        return None;
    }
    let pairs = head.len() / 2;
    let even = head.iter().step_by(2).filter(|&&b| b == 0).count();
    let odd = head.iter().skip(1).step_by(2).filter(|&&b| b == 0).count();
    // ASCII text: at least half the code units have a zero high byte on one side, none on the other
    if odd * 2 >= pairs && even == 0 {
        Some(false)
    } else if even * 2 >= pairs && odd == 0 {
        Some(true)
    } else {
        None
    }
}

/// The delimiter of a CSV text: the most frequent of `,`, `;` and tab in its first line outside double
/// quotes (a comma on a tie, or when the line has none of them).
///
/// ```
/// use millcomp_datasets::decode::sniff_delimiter;
/// assert_eq!(sniff_delimiter("t_s;y_um\n0;1,5\n"), b';');
/// assert_eq!(sniff_delimiter("t_s\ty_um\n"), b'\t');
/// assert_eq!(sniff_delimiter("\"a;b\",c\n"), b',');
/// ```
pub fn sniff_delimiter(text: &str) -> u8 {
    let line = text.lines().next().unwrap_or("");
    let (mut counts, mut quoted) = ([0usize; 3], false);
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => counts[0] += 1,
            ';' if !quoted => counts[1] += 1,
            '\t' if !quoted => counts[2] += 1,
            _ => {}
        }
    }
    let best = [b',', b';', b'\t']
        .into_iter()
        .zip(counts)
        .fold(
            (b',', 0),
            |best, (d, n)| if n > best.1 { (d, n) } else { best },
        );
    best.0
}

/// The number of fields of the first line of a CSV text (delimiters outside double quotes, plus one).
///
/// ```
/// assert_eq!(millcomp_datasets::decode::header_fields("a,\"b,c\",d\n1,2,3\n", b','), 3);
/// ```
pub fn header_fields(text: &str, delimiter: u8) -> usize {
    let line = text.lines().next().unwrap_or("");
    let mut quoted = false;
    1 + line
        .bytes()
        .filter(|&b| {
            if b == b'"' {
                quoted = !quoted;
            }
            b == delimiter && !quoted
        })
        .count()
}

/// The name of a delimiter, for notes.
pub fn delimiter_name(d: u8) -> &'static str {
    match d {
        b';' => "semicolons",
        b'\t' => "tabs",
        _ => "commas",
    }
}

/// A decimal mark.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecimalMark {
    /// `1.5`
    Point,
    /// `1,5`
    Comma,
}

impl DecimalMark {
    fn char(self) -> char {
        match self {
            DecimalMark::Point => '.',
            DecimalMark::Comma => ',',
        }
    }
}

/// One cell read as a number-shaped text.
#[derive(Debug, Clone, PartialEq)]
enum Shape {
    /// Not a number with marks (a plain number, a label, a missing-value marker): left as it is.
    Other,
    /// Only one reading: the number (as Rust parses it) and what it says of the decimal mark, if anything.
    Sure(String, Option<DecimalMark>),
    /// Two readings (`1,234`, `1.234`): with a point or with a comma as the decimal mark.
    Either { point: String, comma: String },
}

fn is_group_mark(c: char) -> bool {
    matches!(c, '.' | ',' | ' ' | '\u{a0}' | '\u{202f}' | '\'')
}

/// Reads one cell's shape: sign, digits with marks, an optional exponent.
fn shape(cell: &str) -> Shape {
    let t = cell.trim();
    let (sign, rest) = match t.strip_prefix('-') {
        Some(r) => ("-", r),
        None => ("", t.strip_prefix('+').unwrap_or(t)),
    };
    let (mantissa, exponent) = match rest.find(['e', 'E']) {
        Some(i) => (&rest[..i], &rest[i..]),
        None => (rest, ""),
    };
    if mantissa.is_empty()
        || !mantissa
            .chars()
            .all(|c| c.is_ascii_digit() || is_group_mark(c))
        || !mantissa.starts_with(|c: char| c.is_ascii_digit() || c == '.' || c == ',')
    {
        return Shape::Other;
    }
    if !exponent.is_empty() {
        let digits = exponent[1..].trim_start_matches(['+', '-']);
        if digits.is_empty() || !digits.chars().all(|c| c.is_ascii_digit()) {
            return Shape::Other;
        }
    }
    let marks: Vec<(usize, char)> = mantissa
        .char_indices()
        .filter(|(_, c)| !c.is_ascii_digit())
        .collect();
    if marks.is_empty() {
        return Shape::Other;
    }
    let number = |grouping: Option<char>, decimal: Option<char>| -> Option<String> {
        // digit groups between grouping marks: the first 1–3 digits, the others exactly 3
        let (int, frac) = match decimal.and_then(|d| mantissa.rfind(d)) {
            Some(i) => (&mantissa[..i], Some(&mantissa[i + decimal?.len_utf8()..])),
            None => (mantissa, None),
        };
        if let Some(f) = frac
            && !f.chars().all(|c| c.is_ascii_digit())
        {
            return None;
        }
        let int_digits: String = match grouping {
            Some(g) => {
                let groups: Vec<&str> = int.split(g).collect();
                // a group mark after a leading 0 (`0.500`) is a decimal mark, never a group
                if groups.len() < 2
                    || !(1..=3).contains(&groups[0].len())
                    || groups[0].starts_with('0')
                    || groups[1..].iter().any(|x| x.len() != 3)
                    || groups
                        .iter()
                        .any(|x| !x.chars().all(|c| c.is_ascii_digit()))
                {
                    return None;
                }
                groups.concat()
            }
            None => {
                if !int.chars().all(|c| c.is_ascii_digit()) {
                    return None;
                }
                int.to_string()
            }
        };
        if int_digits.is_empty() && frac.is_none_or(str::is_empty) {
            return None;
        }
        Some(match frac {
            Some(f) => format!("{sign}{int_digits}.{f}{exponent}"),
            None => format!("{sign}{int_digits}{exponent}"),
        })
    };
    let kinds: Vec<char> = {
        let mut k: Vec<char> = marks.iter().map(|(_, c)| *c).collect();
        k.dedup();
        k
    };
    let last = marks[marks.len() - 1].1;
    let count = |c: char| marks.iter().filter(|(_, m)| *m == c).count();
    let sure = |s: Option<String>, mark: Option<DecimalMark>| match s {
        Some(s) => Shape::Sure(s, mark),
        None => Shape::Other,
    };
    let mark_of = |c: char| match c {
        ',' => Some(DecimalMark::Comma),
        '.' => Some(DecimalMark::Point),
        _ => None,
    };
    match kinds.as_slice() {
        // one mark, once
        [m] if marks.len() == 1 => {
            let after = mantissa.len() - marks[0].0 - 1;
            let before = marks[0].0;
            match m {
                '.' | ',' if after == 3 && (1..=3).contains(&before) => {
                    match (number(None, Some(*m)), number(Some(*m), None)) {
                        (Some(dec), Some(grouped)) => {
                            if *m == '.' {
                                Shape::Either {
                                    point: dec,
                                    comma: grouped,
                                }
                            } else {
                                Shape::Either {
                                    point: grouped,
                                    comma: dec,
                                }
                            }
                        }
                        // `0.500`: a leading zero does not group, so the mark is a decimal one
                        (Some(dec), None) => Shape::Sure(dec, mark_of(*m)),
                        _ => Shape::Other,
                    }
                }
                '.' | ',' => sure(number(None, Some(*m)), mark_of(*m)),
                // a space or an apostrophe only groups
                g => sure(number(Some(*g), None), None),
            }
        }
        // one mark, several times: it groups
        [g] => {
            let implied = match g {
                '.' => Some(DecimalMark::Comma),
                ',' => Some(DecimalMark::Point),
                _ => None,
            };
            sure(number(Some(*g), None), implied)
        }
        // two marks: the last, once, is the decimal mark; the other groups
        [_, _] if count(last) == 1 && mark_of(last).is_some() => {
            let g = kinds.iter().copied().find(|&c| c != last).unwrap_or(' ');
            sure(number(Some(g), Some(last)), mark_of(last))
        }
        _ => Shape::Other,
    }
}

/// The decimal mark a column's cells show by themselves: `Ok(None)` when no cell can be read only one
/// way, `Err(i)` for the first cell (0-based) contradicting an earlier one.
fn column_mark(shapes: &[Shape]) -> Result<Option<DecimalMark>, usize> {
    let mut mark: Option<DecimalMark> = None;
    for (i, s) in shapes.iter().enumerate() {
        if let Shape::Sure(_, Some(m)) = s {
            match mark {
                None => mark = Some(*m),
                Some(prev) if prev != *m => return Err(i),
                Some(_) => {}
            }
        }
    }
    Ok(mark)
}

/// Normalises the numbers of a file's columns in place (see the module docs) and returns, per column,
/// the decimal mark it read them with when that changed a cell (a decimal comma, a digit group), for a
/// note. A column whose cells do not tell (`1,234` only) takes the mark the file's other columns show,
/// or, when none does or they disagree, the file's convention: decimal commas when `comma_by_default`
/// (a file separated by semicolons or tabs), decimal points otherwise.
///
/// ```
/// use millcomp_datasets::decode::{normalise_columns, DecimalMark};
/// let col = |cells: &[&str]| cells.iter().map(|c| Some(c.to_string())).collect::<Vec<_>>();
/// let mut cols = vec![col(&["1,5", "1.234,25", "NA"])];
/// assert_eq!(normalise_columns(&mut cols, true), Ok(vec![Some(DecimalMark::Comma)]));
/// assert_eq!(cols[0], col(&["1.5", "1234.25", "NA"]));
/// // `1,234` is read with the column's decimal mark: here a point, so the comma groups
/// let mut cols = vec![col(&["1,234", "0.5"])];
/// assert_eq!(normalise_columns(&mut cols, true), Ok(vec![Some(DecimalMark::Point)]));
/// assert_eq!(cols[0], col(&["1234", "0.5"]));
/// // a column that does not tell follows the others: decimal points in a semicolon file
/// let mut cols = vec![col(&["1.500", "2.250"]), col(&["0.25"])];
/// assert_eq!(normalise_columns(&mut cols, true), Ok(vec![None, None]));
/// assert_eq!(cols[0], col(&["1.500", "2.250"]));
/// // cells that contradict each other: the column and the first row that does (0-based)
/// let mut cols = vec![col(&["x"]), col(&["1,5", "2.5"])];
/// assert_eq!(normalise_columns(&mut cols, true), Err((1, 1)));
/// ```
///
/// # Errors
/// `(column, cell)`, 0-based, of the first cell whose decimal mark contradicts its column's earlier
/// cells; nothing is changed then.
pub fn normalise_columns(
    columns: &mut [Vec<Option<String>>],
    comma_by_default: bool,
) -> Result<Vec<Option<DecimalMark>>, (usize, usize)> {
    let shapes: Vec<Vec<Shape>> = columns
        .iter()
        .map(|cells| {
            cells
                .iter()
                .map(|c| c.as_deref().map_or(Shape::Other, shape))
                .collect()
        })
        .collect();
    let mut marks = Vec::with_capacity(shapes.len());
    for (j, s) in shapes.iter().enumerate() {
        marks.push(column_mark(s).map_err(|i| (j, i))?);
    }
    let seen = |m: DecimalMark| marks.contains(&Some(m));
    let file_mark = match (seen(DecimalMark::Point), seen(DecimalMark::Comma)) {
        (true, false) => DecimalMark::Point,
        (false, true) => DecimalMark::Comma,
        _ if comma_by_default => DecimalMark::Comma,
        _ => DecimalMark::Point,
    };
    let mut out = Vec::with_capacity(columns.len());
    for ((cells, shapes), mark) in columns.iter_mut().zip(shapes).zip(marks) {
        let column_mark = mark.unwrap_or(file_mark);
        let mut changed = false;
        for (cell, s) in cells.iter_mut().zip(shapes) {
            let new = match s {
                Shape::Other => continue,
                Shape::Sure(n, _) => n,
                Shape::Either { point, comma } => match column_mark {
                    DecimalMark::Point => point,
                    DecimalMark::Comma => comma,
                },
            };
            if cell.as_deref() != Some(new.as_str()) {
                changed = true;
                *cell = Some(new);
            }
        }
        out.push(changed.then_some(column_mark));
    }
    Ok(out)
}

/// The note for a column whose numbers were normalised.
pub fn number_note(column: &str, mark: DecimalMark) -> String {
    format!(
        "column `{column}`: numbers read with `{}` as the decimal mark (digit groups dropped)",
        mark.char()
    )
}

/// A column name with its unit spelled the ASCII way millcomp's names use: `µm` (micro sign or Greek
/// mu) as `um`, `°C` as `C`, a bare `°` as `deg`; `None` when the name has none of them.
///
/// ```
/// use millcomp_datasets::decode::ascii_unit_name;
/// assert_eq!(ascii_unit_name("y_µm").as_deref(), Some("y_um"));
/// assert_eq!(ascii_unit_name("temp_°C").as_deref(), Some("temp_C"));
/// assert_eq!(ascii_unit_name("tilt_°").as_deref(), Some("tilt_deg"));
/// assert_eq!(ascii_unit_name("y_um"), None);
/// ```
pub fn ascii_unit_name(name: &str) -> Option<String> {
    if !name.contains(['µ', 'μ', '°']) {
        return None;
    }
    let mut out = String::with_capacity(name.len());
    let mut chars = name.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            'µ' | 'μ' => out.push('u'),
            '°' if chars.peek().is_some_and(|n| n.is_alphabetic()) => {}
            '°' => out.push_str("deg"),
            other => out.push(other),
        }
    }
    Some(out)
}

/// Cells that mark a missing value in what spreadsheets and instruments write.
pub const MISSING_MARKERS: [&str; 10] = [
    "NA", "N/A", "n/a", "#N/A", "na", "null", "NULL", "None", "-", "?",
];

/// Whether a cell marks a missing value (see [`MISSING_MARKERS`]).
pub fn is_missing_marker(cell: &str) -> bool {
    MISSING_MARKERS.contains(&cell.trim())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn norm(cells: &[&str], comma: bool) -> (Vec<String>, Result<Option<DecimalMark>, usize>) {
        let mut c = vec![
            cells
                .iter()
                .map(|s| Some(s.to_string()))
                .collect::<Vec<_>>(),
        ];
        let r = normalise_columns(&mut c, comma)
            .map(|m| m[0])
            .map_err(|(_, i)| i);
        (
            c.remove(0)
                .into_iter()
                .map(Option::unwrap_or_default)
                .collect(),
            r,
        )
    }

    #[test]
    fn decimal_commas_and_groups_give_the_numbers_of_the_plain_file() {
        let (c, r) = norm(&["0,239249", "-1,5e-3", "12", "1.234.567,5", "+3,25"], true);
        assert_eq!(c, ["0.239249", "-1.5e-3", "12", "1234567.5", "3.25"]);
        assert_eq!(r, Ok(Some(DecimalMark::Comma)));
        for (cell, plain) in c.iter().zip([0.239249, -1.5e-3, 12.0, 1234567.5, 3.25]) {
            assert_eq!(cell.parse::<f64>().unwrap(), plain);
        }
        let (c, _) = norm(&["1 234,5", "1\u{a0}234,5", "1\u{202f}234"], true);
        assert_eq!(c, ["1234.5", "1234.5", "1234"]);
        assert_eq!(norm(&["1'234.5"], true).0, ["1234.5"]);
        // a decimal point in a column of decimal commas contradicts it
        assert_eq!(norm(&["1 234,5", "1'234.5"], true).1, Err(1));
        // plain numbers with decimal points are left as written (no note)
        assert_eq!(
            norm(&["0.00005", "1.5", "2"], false),
            (vec!["0.00005".into(), "1.5".into(), "2".into()], Ok(None))
        );
    }

    #[test]
    fn ambiguous_cells_follow_the_column_then_the_file() {
        // no cell tells: a semicolon file reads decimal commas, a comma file decimal points
        assert_eq!(norm(&["1,234"], true).0, ["1.234"]);
        assert_eq!(norm(&["1,234"], false).0, ["1234"]);
        assert_eq!(norm(&["1.234"], true).0, ["1234"]);
        assert_eq!(norm(&["1.234"], false).0, ["1.234"]);
        // a cell that tells decides for the others
        assert_eq!(norm(&["1.234", "0,5"], false).0, ["1234", "0.5"]);
        // a leading zero is never a digit group: `0.500` is a half wherever it is
        assert_eq!(norm(&["0.500"], true).0, ["0.500"]);
        assert_eq!(norm(&["0,500"], false).0, ["0.500"]);
    }

    #[test]
    fn labels_plain_numbers_and_missing_markers_are_left_alone() {
        let cells = [
            "S7", "radial", "10", "-3", "1e-4", "NA", "", "1.2.3", "12:30", "v1.5",
        ];
        let (c, r) = norm(&cells, true);
        assert_eq!(c, cells);
        assert_eq!(r, Ok(None));
        assert!(is_missing_marker(" NA ") && is_missing_marker("#N/A") && !is_missing_marker("0"));
    }

    #[test]
    fn utf16_without_bom_and_binary_bytes() {
        let plain = "t_s,y_um\n0,1\n";
        let le: Vec<u8> = plain.encode_utf16().flat_map(|u| u.to_le_bytes()).collect();
        let be: Vec<u8> = plain.encode_utf16().flat_map(|u| u.to_be_bytes()).collect();
        assert_eq!(
            decode_text(&le).unwrap(),
            (
                Cow::Borrowed(plain),
                TextEncoding::Utf16 {
                    big_endian: false,
                    bom: false
                }
            )
        );
        assert_eq!(decode_text(&be).unwrap().0, plain);
        assert!(decode_text(b"PK\x03\x04\x00\x00\x08\x00\x99\x00").is_err());
        let mut utf8 = b"\xEF\xBB\xBF".to_vec();
        utf8.extend_from_slice(plain.as_bytes());
        assert_eq!(decode_text(&utf8).unwrap().0, plain);
    }
}
