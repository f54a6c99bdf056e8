//! Delimited numeric text, as recorders write it: the line splitting shared
//! by the MMSys'17, OpenXR and generic CSV importers.
//!
//! - The delimiter is taken from the first content line: `,` if it has
//!   one, else `;`, else runs of whitespace (spaces, tabs). Fields are
//!   trimmed (pred6dof writes `, ` between values) and one pair of
//!   surrounding double quotes is removed (spreadsheet exports).
//! - Blank lines and lines starting with `#` are skipped; a leading UTF-8
//!   byte-order mark is ignored.
//! - Every row has the field count of the header (or of the first row when
//!   there is no header); another count is an error naming the line —
//!   except for a **truncated final line**: the last line, without a
//!   newline at the end of the file, with fewer fields. A recorder stopped
//!   mid-write leaves one (pred6dof's `12.csv` ends in
//!   `637231093681476118, 0.07112393, 0.0713555142, 1.0741663, -0.`); it is
//!   dropped with a warning naming the line instead of failing the file.

use super::trace::{TraceBuilder, TraceError};

/// Whether the first content line is a header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum HeaderRule {
    /// The format has a header line.
    Required,
    /// The format has none: every line is data.
    Never,
    /// A header when no field of the first line is a number.
    Detect,
}

/// One line split into fields.
#[derive(Debug)]
pub(crate) struct Record<'a> {
    /// 1-based line number in the file.
    pub line: usize,
    /// Trimmed fields.
    pub fields: Vec<&'a str>,
}

/// The split file.
#[derive(Debug)]
pub(crate) struct Table<'a> {
    /// The header line, if the format or the data has one.
    pub header: Option<Record<'a>>,
    /// Data rows, all with the same field count.
    pub rows: Vec<Record<'a>>,
}

fn unquote(s: &str) -> &str {
    let s = s.trim();
    s.strip_prefix('"')
        .and_then(|t| t.strip_suffix('"'))
        .map(str::trim)
        .unwrap_or(s)
}

fn split(line: &str, delimiter: Option<char>) -> Vec<&str> {
    match delimiter {
        Some(d) => line.split(d).map(unquote).collect(),
        None => line.split_whitespace().map(unquote).collect(),
    }
}

/// Splits `text` into a header and rows (module docs). `expected` names the
/// format in the empty-file error, e.g. "a header `time,...` and samples".
pub(crate) fn read_table<'a>(
    b: &mut TraceBuilder,
    text: &'a str,
    rule: HeaderRule,
    expected: &str,
) -> Result<Table<'a>, TraceError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let ends_with_newline = text.ends_with('\n');
    let lines: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
        .collect();
    let Some(&(first_line, first)) = lines.first() else {
        return Err(b.line_error(1, format!("empty file; expected {expected}")));
    };
    let delimiter = if first.contains(',') {
        Some(',')
    } else if first.contains(';') {
        Some(';')
    } else {
        None
    };
    let first_fields = split(first, delimiter);
    let is_header = match rule {
        HeaderRule::Required => true,
        HeaderRule::Never => false,
        // Every field non-numeric: a data line with one damaged number stays
        // data (and its error names the field) instead of being skipped.
        HeaderRule::Detect => first_fields.iter().all(|f| f.parse::<f64>().is_err()),
    };
    let mut header = None;
    let mut rest = &lines[..];
    if is_header {
        header = Some(Record {
            line: first_line,
            fields: first_fields.clone(),
        });
        rest = &lines[1..];
    }
    let n_fields = first_fields.len();
    let count_from = first_line;
    let mut rows = Vec::with_capacity(rest.len());
    let last_index = rest.len().saturating_sub(1);
    for (k, &(line, raw)) in rest.iter().enumerate() {
        let fields = split(raw, delimiter);
        if fields.len() != n_fields {
            let truncated = k == last_index && !ends_with_newline && fields.len() < n_fields;
            if truncated {
                b.warn(
                    Some(line),
                    format!(
                        "truncated final line ({} of {n_fields} fields, no newline at the end of the file): dropped, the recording was cut off mid-write",
                        fields.len()
                    ),
                );
                continue;
            }
            return Err(b.line_error(
                line,
                format!("{} fields, line {count_from} has {n_fields}", fields.len()),
            ));
        }
        rows.push(Record { line, fields });
    }
    if rows.is_empty() {
        let line = header.as_ref().map_or(first_line, |h| h.line + 1);
        return Err(b.line_error(
            line,
            format!("no samples; a trace needs at least one (expected {expected})"),
        ));
    }
    Ok(Table { header, rows })
}
