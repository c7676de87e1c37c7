//! The one TOML key locator behind every file kind's error messages (design files,
//! experiment definitions): the line and column of a byte offset, the dotted key at an
//! offset, the line where `table[index].key` is set, and a `toml::de::Error` turned into a
//! line, a column, a key and a message.
//!
//! The files are hand-written, so the search is textual: it follows `[table]` and
//! `[[table]]` headers (counting the occurrences of an array of tables), `key =` lines,
//! `table = { key = ... }` inline tables inside the parent table, and `#` comments. It is
//! meant for pointing a person at a line, not for parsing: the parser has already read the
//! file (or failed with a span) by the time a key is located.

use std::ops::Range;

/// 1-based line and column (in characters) of byte `offset` of `text`; offsets past the end
/// count as the end.
pub fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = char_floor(text, offset);
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// The dotted key whose value (or name) is at byte `offset`: the last `[table]` header
/// before it and the nearest `key =` on its line at or before the offset (or, where the line
/// has no `=` before the offset, the name starting at the offset: an unknown key). On a
/// header line, the table before it.
pub fn key_at(text: &str, offset: usize) -> Option<String> {
    let offset = char_floor(text, offset);
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let line = &text[line_start..line_end];
    let upto = offset - line_start;
    let table = text[..line_start].lines().rev().find_map(|l| {
        let l = l.trim();
        l.strip_prefix('[').map(|h| h.trim_start_matches('[').trim_end_matches(']').trim().to_owned())
    });
    if line.trim_start().starts_with('[') {
        return table;
    }
    // The key: either the word at the offset (an unknown key) or the one before the last `=`.
    let head = &line[..upto.min(line.len())];
    let name = match head.rfind('=') {
        Some(eq) => {
            let before = head[..eq].trim_end();
            let start = before.char_indices().rfind(|&(_, c)| !is_key_char(c)).map_or(0, |(i, c)| i + c.len_utf8());
            before[start..].to_owned()
        }
        None => line[upto.min(line.len())..].chars().take_while(|&c| is_key_char(c)).collect(),
    };
    if name.is_empty() {
        return table;
    }
    Some(match table {
        Some(t) => format!("{t}.{name}"),
        None => name,
    })
}

/// `offset` moved back to the start of the character it falls in (a parser's span may point
/// inside a multi-byte character), and to the end at most.
fn char_floor(text: &str, offset: usize) -> usize {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    offset
}

fn is_key_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_' || c == '-' || c == '.'
}

/// 1-based line where `key` is set inside `table` (`""`: the top level; `a.b`: the table
/// `[a.b]`), in the `index`-th (0-based) `[[table]]` for arrays of tables (`None`: any
/// occurrence). Also finds `b = { key = ... }` written inside `[a]` for `table` `a.b`.
///
/// Where the key is not written (a missing key), the line of the table's header: the
/// `index`-th for arrays of tables, the first otherwise. `None` when neither is in the text
/// (a table only implied by its sub-tables' headers, or a key of a missing table).
pub fn key_line(text: &str, table: &str, index: Option<usize>, key: &str) -> Option<usize> {
    let mut current = String::new();
    // How many `[[table]]` headers have been seen (the occurrence being read is this minus 1).
    let mut occurrences = 0usize;
    let mut header = None;
    let (parent, last) = table.rsplit_once('.').unwrap_or(("", table));
    let sets = |line: &str, k: &str| line.strip_prefix(k).is_some_and(|rest| rest.trim_start().starts_with('='));
    for (n, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if let Some(h) = line.strip_prefix("[[") {
            current = h.split("]]").next().unwrap_or("").trim().to_owned();
            if current == table {
                occurrences += 1;
                if header.is_none() && index.is_none_or(|i| i + 1 == occurrences) {
                    header = Some(n + 1);
                }
            }
            continue;
        }
        if let Some(h) = line.strip_prefix('[') {
            current = h.split(']').next().unwrap_or("").trim().to_owned();
            if current == table && header.is_none() {
                header = Some(n + 1);
            }
            continue;
        }
        let in_table = current == table && index.is_none_or(|i| i + 1 == occurrences);
        if in_table && sets(line, key) {
            return Some(n + 1);
        }
        // `last = { key = ... }` inside `[parent]`.
        if current == parent && index.is_none() && sets(line, last) && line.contains(&format!("{key} ")) {
            return Some(n + 1);
        }
    }
    header
}

/// The first name between backticks in `message` (toml names unknown and missing keys that
/// way: ``unknown field `speed`, expected ...``).
pub fn backticked(message: &str) -> Option<String> {
    let start = message.find('`')? + 1;
    let len = message[start..].find('`')?;
    Some(message[start..start + len].to_owned())
}

/// Where a `toml::de::Error` points in the text it came from, and what it says.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TomlError {
    /// 1-based line of the error's span (1 without a span).
    pub line: usize,
    /// 1-based column of the error's span (1 without a span).
    pub column: usize,
    /// Byte range the parser blamed, when it gave one.
    pub span: Option<Range<usize>>,
    /// The dotted key the error is about: the key path toml names, else the key written at
    /// the span ([`key_at`]).
    pub key: Option<String>,
    /// toml's message, as it gives it (without the input excerpt).
    pub message: String,
}

impl TomlError {
    /// Locates `error`, which came from parsing `text`.
    pub fn new(text: &str, error: &toml::de::Error) -> TomlError {
        let span = error.span();
        let (line, column) = span.as_ref().map_or((1, 1), |span| line_column(text, span.start));
        // toml names the key path only in its display without input context.
        let mut bare = error.clone();
        bare.set_input(None);
        let shown = bare.to_string();
        let key = shown
            .lines()
            .find_map(|l| l.strip_prefix("in `").and_then(|r| r.strip_suffix('`')))
            .map(str::to_owned)
            .or_else(|| span.as_ref().and_then(|span| key_at(text, span.start)));
        TomlError { line, column, span, key, message: error.message().to_owned() }
    }

    /// The text of the span up to its first `=`, trimmed: the key as written when the span
    /// covers a `key = value` line (`None` without a span).
    pub fn written_key<'a>(&self, text: &'a str) -> Option<&'a str> {
        let span = self.span.clone()?;
        Some(text.get(span)?.split('=').next().unwrap_or("").trim())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_inside_multibyte_characters_do_not_panic() {
        // Found by the fuzz test: a parser span pointing into a replacement character.
        let text = "a\u{fffd}\u{fffd} = 1\n[t]\n\u{e9}b = 2\n";
        for offset in 0..text.len() + 3 {
            let _ = line_column(text, offset);
            let _ = key_at(text, offset);
        }
        assert_eq!(line_column(text, 2), (1, 2));
        assert_eq!(key_at(text, text.len() - 2).as_deref(), Some("t.\u{e9}b"));
    }

    const TEXT: &str = "name = \"x\"\n[sequence]\nfps = \"thirty\"\nbogus = 1\n[lighting]\nenvironment = { kind = \"file\", path = 3 }\n";

    #[test]
    fn line_column_counts_lines_and_characters() {
        let text = "a = 1\nb = \"é\" x\n";
        assert_eq!(line_column(text, 0), (1, 1));
        assert_eq!(line_column(text, text.find('b').unwrap()), (2, 1));
        assert_eq!(line_column(text, text.find('x').unwrap()), (2, 9));
        assert_eq!(line_column(text, 10_000), (3, 1));
    }

    #[test]
    fn key_at_finds_keys_of_values_and_unknown_names() {
        let at = |needle: &str| key_at(TEXT, TEXT.find(needle).unwrap());
        assert_eq!(at("\"thirty\"").as_deref(), Some("sequence.fps"));
        assert_eq!(at("bogus").as_deref(), Some("sequence.bogus"));
        assert_eq!(at("3 }").as_deref(), Some("lighting.path"));
        assert_eq!(at("\"x\"").as_deref(), Some("name"));
        assert_eq!(at("[lighting]").as_deref(), Some("sequence"));
    }

    #[test]
    fn key_line_finds_top_level_table_and_inline_keys() {
        assert_eq!(key_line(TEXT, "", None, "name"), Some(1));
        assert_eq!(key_line(TEXT, "sequence", None, "fps"), Some(3));
        assert_eq!(key_line(TEXT, "lighting.environment", None, "path"), Some(6));
        // `fps` is not a key of the top level or of `[lighting]`.
        assert_eq!(key_line(TEXT, "", None, "fps"), None);
        assert_eq!(key_line(TEXT, "lighting", None, "fps"), Some(5));
    }

    const ARRAYS: &str = "format = \"f\"\n\n[stimuli] # the levels\nspeed = [2]\n\n[[practice]]\npair = [\"a\", \"b\"]\n\
        [[practice]]\npair = [\"c\", \"d\"]\nreference = \"c\"\n[[practice]]\n# pair = [\"e\", \"f\"]\n\
        [briefing]\ntext = \"x\"\n[[briefing.examples]]\nlabel = \"Noise\"\n";

    #[test]
    fn key_line_counts_the_occurrences_of_an_array_of_tables() {
        assert_eq!(key_line(ARRAYS, "practice", Some(0), "pair"), Some(7));
        assert_eq!(key_line(ARRAYS, "practice", Some(1), "pair"), Some(9));
        assert_eq!(key_line(ARRAYS, "practice", Some(1), "reference"), Some(10));
        assert_eq!(key_line(ARRAYS, "practice", None, "reference"), Some(10));
        assert_eq!(key_line(ARRAYS, "briefing.examples", Some(0), "label"), Some(16));
        // `[briefing]`'s keys are not its sub-table's.
        assert_eq!(key_line(ARRAYS, "briefing", None, "label"), Some(13));
    }

    #[test]
    fn a_missing_key_falls_back_to_its_tables_header() {
        // The commented-out key does not count; the third `[[practice]]` header does.
        assert_eq!(key_line(ARRAYS, "practice", Some(2), "pair"), Some(11));
        assert_eq!(key_line(ARRAYS, "practice", None, "stimulus"), Some(6));
        // A header with a trailing comment.
        assert_eq!(key_line(ARRAYS, "stimuli", None, "samples"), Some(3));
        assert_eq!(key_line(ARRAYS, "presentation", None, "loops"), None);
        assert_eq!(key_line(ARRAYS, "practice", Some(5), "pair"), None);
    }

    #[test]
    fn backticked_takes_the_first_quoted_name() {
        assert_eq!(backticked("unknown field `speed`, expected one of `a`").as_deref(), Some("speed"));
        assert_eq!(backticked("invalid type: string"), None);
        assert_eq!(backticked("unclosed `quote"), None);
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct File {
        name: String,
        sequence: Sequence,
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Sequence {
        fps: f64,
    }

    fn error_of(text: &str) -> TomlError {
        TomlError::new(text, &toml::from_str::<File>(text).unwrap_err())
    }

    #[test]
    fn toml_errors_get_a_line_column_key_and_message() {
        let text = "name = \"x\"\n[sequence]\nfps = \"thirty\"\n";
        let e = error_of(text);
        assert_eq!((e.line, e.column), (3, 7));
        assert_eq!(e.key.as_deref(), Some("sequence.fps"));
        assert!(e.message.contains("invalid type"), "{}", e.message);
        assert_eq!(e.written_key(text), Some("\"thirty\""));

        let text = "name = \"x\"\n[sequence]\nfps = 30.0\nbogus = 1\n";
        let e = error_of(text);
        // toml names the table of an unknown key, and the key in its message.
        assert_eq!(e.line, 4);
        assert_eq!(e.key.as_deref(), Some("sequence"));
        assert_eq!(backticked(&e.message).as_deref(), Some("bogus"));

        let text = "name = \"x\"\nsequence = 3 3\n";
        let e = error_of(text);
        assert_eq!(e.line, 2);
        assert!(e.span.is_some());
    }
}
