//! Typed YAML specs: base scenarios (`specs/scenarios/*.yaml`), planner
//! adapters (`planners/*.yaml`) and suites (`specs/suites/*.yaml`).
//!
//! Every spec is a serde struct with `deny_unknown_fields`, so a typo is an
//! error. Parsing errors come from serde-saphyr with line, column and a
//! snippet (library-facing wording put in a spec author's words); our own
//! validation (every number finite and in a documented range, an `ego:`
//! naming no agent, a name that cannot be a path part) points at the
//! offending value through [`locate`] (a dotted path such as
//! `agents[2].length_m`) or `Spanned` values. Errors carry the file's text
//! so the CLI can render them ([`SpecError::render`]).
//! `safer schema` exports a JSON Schema per spec kind for editors.

pub mod locate;
pub mod paths;
pub mod planner;
pub mod scenario;
#[cfg(feature = "embedded-files")]
pub mod shipped_files;
pub mod suite;

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

/// The name a unit enum value has in spec files and reports (its serde
/// name, e.g. `no-lfr`); empty for a value that is not serialised as a string.
pub fn spec_name<T: serde::Serialize>(value: &T) -> String {
    serde_json::to_value(value).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default()
}

/// A position in a spec file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SpecLocation {
    /// 1-based line.
    pub line: u64,
    /// 1-based column.
    pub column: u64,
}

impl SpecLocation {
    /// From a serde-saphyr location (`None` when it is unknown, 0:0).
    pub fn from_saphyr(l: &serde_saphyr::Location) -> Option<Self> {
        (l.line() > 0).then(|| Self { line: l.line(), column: l.column() })
    }
}

/// Why a spec could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}", path = path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// YAML syntax or a value of the wrong shape or type.
    #[error("{path}{location}: {message}", path = path.display(), location = fmt_location(location))]
    Parse {
        /// The file.
        path: PathBuf,
        /// Where, when known.
        location: Option<SpecLocation>,
        /// What is wrong and what was expected.
        message: String,
        /// The file's text, for rendering the snippet.
        text: String,
    },
    /// The YAML parsed but says something impossible.
    #[error("{path}{location}: {message}", path = path.display(), location = fmt_location(location))]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Where, when known.
        location: Option<SpecLocation>,
        /// What is wrong and what would be accepted.
        message: String,
        /// The file's text.
        text: String,
    },
    /// A file a spec refers to could not be used.
    #[error("{path}{location}: {message}", path = path.display(), location = fmt_location(location))]
    Reference {
        /// The spec file.
        path: PathBuf,
        /// Where the reference is.
        location: Option<SpecLocation>,
        /// What is wrong with the referenced file.
        message: String,
        /// The file's text.
        text: String,
    },
}

/// `:LINE:COLUMN`, or nothing when the place is unknown (an error about a
/// whole file, such as a recorded log that does not import, says where in
/// that file itself).
fn fmt_location(l: &Option<SpecLocation>) -> String {
    l.map_or_else(String::new, |l| format!(":{}:{}", l.line, l.column))
}

impl SpecError {
    /// The spec file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            Self::Io { path, .. }
            | Self::Parse { path, .. }
            | Self::Invalid { path, .. }
            | Self::Reference { path, .. } => path,
        }
    }

    /// The error as a report: the message, the file and place, and the
    /// offending line with the place underlined (as rustc shows its own),
    /// in colour when `colour` is set. A report, never a debug dump.
    pub fn render(&self, colour: bool) -> String {
        let (text, location, message) = match self {
            Self::Io { .. } => return format!("error: {self}"),
            Self::Parse { text, location, message, .. }
            | Self::Invalid { text, location, message, .. }
            | Self::Reference { text, location, message, .. } => (text, location, message),
        };
        render_located(Severity::Error, (self.path(), text, *location), message, colour)
    }
}

/// Something a spec says that is valid but most likely not what its
/// author meant: reported beside the run, not refused (see
/// [`Loaded::warning_at`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SpecWarning {
    /// The spec file.
    pub path: PathBuf,
    /// Where, when known.
    pub location: Option<SpecLocation>,
    /// What the spec does and what to write instead.
    pub message: String,
    /// The file's text, for rendering the snippet.
    text: String,
}

impl std::fmt::Display for SpecWarning {
    /// `PATH:LINE:COLUMN: message`, as a [`SpecError`] reads.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}{}: {}", self.path.display(), fmt_location(&self.location), self.message)
    }
}

impl SpecWarning {
    /// The warning as a report, as [`SpecError::render`] shows an error.
    pub fn render(&self, colour: bool) -> String {
        render_located(Severity::Warning, (&self.path, &self.text, self.location), &self.message, colour)
    }
}

/// The environment variable that makes spec warnings errors, as
/// `safer run --deny-warnings` does (`1`; unset, empty, `0` or `false`
/// leave them warnings): for a CI whose test tool shows only the output of
/// failing tests, as cargo-nextest does.
pub const DENY_WARNINGS_ENV: &str = "SAFER_DENY_WARNINGS";

/// Whether [`DENY_WARNINGS_ENV`] is set to deny spec warnings.
pub fn warnings_denied_by_env() -> bool {
    env_flag(DENY_WARNINGS_ENV)
}

/// Whether a yes/no environment variable is set: unset, empty, `0` and
/// `false` are no.
pub(crate) fn env_flag(name: &str) -> bool {
    std::env::var(name).is_ok_and(|v| !v.is_empty() && v != "0" && v != "false")
}

/// A spec's warnings where the run denies them
/// ([`DENY_WARNINGS_ENV`], `safer run --deny-warnings`): the suite is then
/// refused as a spec error refuses it, and every report says why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WarningsDenied {
    /// The warnings, in the order the spec gives them.
    pub warnings: Vec<SpecWarning>,
}

impl WarningsDenied {
    /// The denial of `warnings`; `None` when there are none to deny.
    pub fn of(warnings: Vec<SpecWarning>) -> Option<Self> {
        (!warnings.is_empty()).then_some(Self { warnings })
    }

    /// Each warning as [`SpecWarning::render`] shows it, then the error
    /// that denies them.
    pub fn render(&self, colour: bool) -> String {
        let mut out: Vec<String> = self.warnings.iter().map(|w| w.render(colour)).collect();
        out.push(format!("error: {}", self.headline()));
        out.join("\n")
    }

    fn headline(&self) -> String {
        let n = self.warnings.len();
        format!(
            "{n} spec warning{} denied ({DENY_WARNINGS_ENV} or --deny-warnings is set): the suite does not run until \
             its spec says what it means",
            if n == 1 { "" } else { "s" }
        )
    }
}

impl std::fmt::Display for WarningsDenied {
    /// The error, then each warning as `PATH:LINE:COLUMN: message` on a line of its own.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.headline())?;
        self.warnings.iter().try_for_each(|w| write!(f, "\n{w}"))
    }
}

/// How a located message is reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Severity {
    Error,
    Warning,
}

/// A message about a place in a spec file: the message, the file and
/// place, and its line with the place underlined.
fn render_located(
    severity: Severity,
    (path, text, location): (&Path, &str, Option<SpecLocation>),
    message: &str,
    colour: bool,
) -> String {
    let path = path.display().to_string();
    if text.is_empty() {
        let word = match severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        return format!("{word}: {path}: {message}");
    }
    let level = match severity {
        Severity::Error => annotate_snippets::Level::ERROR,
        Severity::Warning => annotate_snippets::Level::WARNING,
    };
    let (shown, moved) = shown_excerpt(text, location);
    let offset = moved.map(|l| line_column_to_offset(&shown, l)).unwrap_or(0);
    // Where a long line was cut, the snippet's columns are not the
    // file's: the label gives the file's.
    let label = match location {
        Some(l) if moved != location => format!("here (line {}, column {} of the file)", l.line, l.column),
        _ => "here".to_string(),
    };
    // An empty span at a line's end would underline nothing: mark the
    // character at the place, or the line break after it.
    let end = shown[offset..].chars().next().map_or(offset, |c| offset + c.len_utf8());
    let report = [level.primary_title(message).element(
        annotate_snippets::Snippet::source(shown.as_str())
            .path(path.as_str())
            .annotation(annotate_snippets::AnnotationKind::Primary.span(offset..end).label(label.as_str())),
    )];
    let renderer = if colour { annotate_snippets::Renderer::styled() } else { annotate_snippets::Renderer::plain() };
    renderer.render(&report)
}

fn line_column_to_offset(text: &str, l: SpecLocation) -> usize {
    let mut offset = 0;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        if i + 1 == l.line as usize {
            return offset + line.char_indices().nth(l.column.saturating_sub(1) as usize).map_or(0, |(b, _)| b);
        }
        offset += line.len();
    }
    offset
}

/// A parsed spec with the text it came from, for validation errors.
#[derive(Debug, Clone)]
pub struct Loaded<T> {
    /// The parsed value.
    pub value: T,
    /// The file.
    pub path: PathBuf,
    /// The file's text.
    pub text: String,
}

impl<T> Loaded<T> {
    /// An [`SpecError::Invalid`] at `location` in this file.
    pub fn invalid(&self, location: Option<SpecLocation>, message: impl Into<String>) -> SpecError {
        SpecError::Invalid { path: self.path.clone(), location, message: message.into(), text: self.text.clone() }
    }

    /// A [`SpecWarning`] at the value `path` (or its nearest written
    /// ancestor) in this file.
    pub fn warning_at(&self, path: &str, message: impl Into<String>) -> SpecWarning {
        SpecWarning {
            path: self.path.clone(),
            location: self.at(path),
            message: message.into(),
            text: self.text.clone(),
        }
    }

    /// Whether the file writes the value at `path` (not left to its default).
    pub fn writes(&self, path: &str) -> bool {
        locate::tree(&self.text).is_some_and(|root| root.walk(&locate::parse_path(path)).1)
    }

    /// A [`SpecError::Reference`] at `location` in this file.
    pub fn reference(&self, location: Option<SpecLocation>, message: impl Into<String>) -> SpecError {
        SpecError::Reference { path: self.path.clone(), location, message: message.into(), text: self.text.clone() }
    }

    /// The folder the file is in (relative references resolve against it).
    /// `.` for a bare file name, whose parent is the empty path: an empty
    /// working directory made external planners fail to start.
    pub fn dir(&self) -> &Path {
        self.path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
    }

    /// Where the value at `path` (`acceptance.variant.min_gap_m`,
    /// `agents[2].length_m`) is written, or its nearest written ancestor.
    pub fn at(&self, path: &str) -> Option<SpecLocation> {
        locate::locate(&self.text, path)
    }

    /// An [`SpecError::Invalid`] at the value `path`.
    pub fn invalid_at(&self, path: &str, message: impl Into<String>) -> SpecError {
        self.invalid(self.at(path), message)
    }

    /// An [`SpecError::Reference`] at the value `path`.
    pub fn reference_at(&self, path: &str, message: impl Into<String>) -> SpecError {
        self.reference(self.at(path), message)
    }

    /// Checks that the number written at `path` is finite and within
    /// `range` (`unit` for the message).
    pub fn check_number(&self, path: &str, value: f64, range: NumberRange, unit: &str) -> Result<(), SpecError> {
        if value.is_finite() && range.contains(value) {
            return Ok(());
        }
        let key = path.rsplit('.').next().unwrap_or(path);
        let got = number_text(value);
        Err(self.invalid_at(path, format!("`{key}` must be a number in {} {unit}, got {got}", range.describe())))
    }
}

/// A number as a person wrote it: `1e300`, not three hundred digits.
pub fn number_text(v: f64) -> String {
    crate::number::shown(v)
}

/// A closed or half-open range a spec number must lie in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NumberRange {
    /// Lower bound.
    pub min: f64,
    /// Whether the lower bound itself is allowed.
    pub min_inclusive: bool,
    /// Upper bound (inclusive).
    pub max: f64,
}

impl NumberRange {
    /// `[min, max]`.
    pub const fn closed(min: f64, max: f64) -> Self {
        Self { min, min_inclusive: true, max }
    }

    /// `(min, max]`: for sizes, durations and rates that must be positive.
    pub const fn above(min: f64, max: f64) -> Self {
        Self { min, min_inclusive: false, max }
    }

    fn contains(&self, v: f64) -> bool {
        (if self.min_inclusive { v >= self.min } else { v > self.min }) && v <= self.max
    }

    fn describe(&self) -> String {
        format!("{}{}, {}]", if self.min_inclusive { "[" } else { "(" }, self.min, self.max)
    }
}

/// Parses YAML text (named `path` in messages) into `T`.
pub fn parse_yaml<T: DeserializeOwned>(text: &str, path: &Path) -> Result<Loaded<T>, SpecError> {
    // serde-saphyr's default budgets guard against YAML bombs.
    match serde_saphyr::from_str::<T>(text) {
        Ok(value) => Ok(Loaded { value, path: path.to_path_buf(), text: text.to_string() }),
        Err(e) => {
            let location = e.location().as_ref().and_then(SpecLocation::from_saphyr);
            let mut message = first_line_message(&e);
            // Say where the first of a duplicated key is.
            if let Some(key) = message.strip_prefix("key `").and_then(|m| m.split_once("` appears twice")).map(|k| k.0)
                && let Some(first) = location.and_then(|at| locate::first_occurrence_of_key_at(text, at))
            {
                message =
                    format!("key `{key}` appears twice in the same mapping (first at line {}); keep one", first.line);
            }
            Err(SpecError::Parse {
                path: path.to_path_buf(),
                location,
                message: cut_message(message),
                text: text.to_string(),
            })
        }
    }
}

/// serde-saphyr's Display includes a rendered snippet; our message keeps
/// the first line (the what) and the renderer adds the snippet. Messages
/// that speak to a programmer (which library option to set) are put in a
/// spec author's words.
fn first_line_message(e: &serde_saphyr::Error) -> String {
    let full = e.to_string();
    let first = full.lines().next().unwrap_or(&full).trim();
    let first = first.strip_prefix("error: ").unwrap_or(first);
    // "line L column C: " is repeated by our own location; drop it.
    let what = first.split_once(": ").filter(|(head, _)| head.starts_with("line ")).map_or(first, |(_, rest)| rest);
    plain_words(what)
}

/// Rewrites library-facing YAML messages for spec authors.
fn plain_words(message: &str) -> String {
    if let Some(rest) = message.strip_prefix("duplicate mapping key: ") {
        let key = rest.split(',').next().unwrap_or(rest).trim();
        return format!("key `{key}` appears twice in the same mapping; keep one");
    }
    if message.starts_with("multiple YAML documents detected") {
        return "a spec file holds one YAML document, but a second one starts here (`---`); move it to its own file"
            .to_string();
    }
    if let Some(breach) = message.strip_prefix("budget breached: ") {
        // `Nodes { nodes: 250001 }`: the kind and the count it stopped at.
        let kind = breach.split([' ', '{']).next().unwrap_or(breach);
        let count: String = breach.chars().filter(char::is_ascii_digit).collect();
        let what = match kind {
            "Events" => "parser events",
            "Aliases" => "aliases (`*name`)",
            "Anchors" => "anchors (`&name`)",
            "Depth" => "levels of nesting",
            "Documents" => "documents",
            "Nodes" => "values",
            "ScalarBytes" => "bytes of text in values",
            "CommentBytes" => "bytes of comments",
            "InputBytes" => "bytes of input",
            "MergeKeys" => "merge keys (`<<`)",
            "AliasAnchorRatio" | "RecordedAnchorEvents" | "RecordedAnchorBytes" => "alias expansion",
            _ => "YAML elements",
        };
        return format!(
            "the spec goes past the parser's limit on {what} (it stopped at {count}); a spec this large is a \
             generated file or a YAML bomb, not a hand-written spec"
        );
    }
    if message == "recursion limit exceeded" {
        return "lists or mappings nest deeper than the parser allows; a spec nests a few levels".to_string();
    }
    if message.starts_with("unexpected end of input") {
        return "the file is empty or ends early: a spec is one YAML mapping (`key: value` lines)".to_string();
    }
    // The two untagged enums of a suite (their shapes are checked first,
    // so what reaches here is a value of the wrong type).
    if message.starts_with("data did not match any variant of untagged enum PlannerRef") {
        return "`planner:` takes a planner spec file (a path), `builtin: NAME` or `rust: NAME`".to_string();
    }
    if message.starts_with("data did not match any variant of untagged enum ScenarioEntry") {
        return "a `scenarios:` entry is a scenario spec path, `glob: PATTERN`, or `recorded: PATH` with an optional \
                `limit: N` (a whole number of scenes, at least 1) and `roles: PAIRING` (as-loaded, merging or leader)"
            .to_string();
    }
    if message == "expected mapping start" {
        return "expected a mapping (`key: value` lines) here".to_string();
    }
    if let Some(kind) = message.strip_prefix("invalid ").filter(|k| ["u8", "u16", "u32", "u64", "usize"].contains(k)) {
        let max = match kind {
            "u8" => u64::from(u8::MAX),
            "u16" => u64::from(u16::MAX),
            "u32" => u64::from(u32::MAX),
            _ => u64::MAX,
        };
        return format!("expected a whole number from 0 to {max} here");
    }
    message.to_string()
}

/// Reads and parses a YAML spec file.
pub fn load_yaml<T: DeserializeOwned>(path: &Path) -> Result<Loaded<T>, SpecError> {
    parse_yaml(&read_text(path)?, path)
}

/// A spec file's text; a file that is not UTF-8 is refused at its first
/// bad byte.
pub fn read_text(path: &Path) -> Result<String, SpecError> {
    use std::io::Read;
    let io = |source| SpecError::Io { path: path.to_path_buf(), source };
    let mut bytes = Vec::new();
    // Read at most one byte past the limit: a huge file (or an endless
    // device) is refused without being read whole.
    std::fs::File::open(path).and_then(|f| f.take(MAX_SPEC_BYTES + 1).read_to_end(&mut bytes)).map_err(io)?;
    if bytes.len() as u64 > MAX_SPEC_BYTES {
        return Err(SpecError::Parse {
            path: path.to_path_buf(),
            location: None,
            message: format!(
                "the file is larger than {} MiB, the most a spec may be (specs are written by hand; recorded \
                 scenes go in `recorded:` entries)",
                MAX_SPEC_BYTES >> 20
            ),
            text: String::new(),
        });
    }
    String::from_utf8(bytes).map_err(|e| not_utf8(path, e))
}

/// The largest spec file read, bytes (1 MiB: the shipped specs are under
/// 16 KiB). A bigger file is refused before it is parsed, so neither the
/// parser's time and memory nor an echoed line can grow with it.
pub const MAX_SPEC_BYTES: u64 = 1 << 20;

/// The most characters of one line an error shows; a longer line is cut
/// to a window around the place the error points at.
const MAX_SHOWN_LINE_CHARS: usize = 240;

/// The most characters of an error's message (a parser message can quote
/// a whole value).
const MAX_MESSAGE_CHARS: usize = 400;

/// `message` cut to [`MAX_MESSAGE_CHARS`].
fn cut_message(message: String) -> String {
    crate::message_text::cut_with_length(&message, MAX_MESSAGE_CHARS)
}

/// `text` with every line longer than [`MAX_SHOWN_LINE_CHARS`] cut to a
/// window (around `location`'s column on its line, from the start on
/// others), and the location moved to match: the lines keep their
/// numbers, so the snippet still says where.
fn shown_excerpt(text: &str, location: Option<SpecLocation>) -> (String, Option<SpecLocation>) {
    if text.lines().all(|l| l.len() <= MAX_SHOWN_LINE_CHARS) {
        return (text.to_string(), location);
    }
    let mut out = String::new();
    let mut moved = location;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let (body, end) = line.strip_suffix('\n').map_or((line, ""), |b| (b, "\n"));
        let chars = body.chars().count();
        if chars <= MAX_SHOWN_LINE_CHARS {
            out.push_str(line);
            continue;
        }
        let here = location.filter(|l| l.line as usize == i + 1);
        let column = here.map_or(0, |l| l.column.saturating_sub(1) as usize).min(chars);
        let start = column.saturating_sub(MAX_SHOWN_LINE_CHARS / 2);
        let window: String = body.chars().skip(start).take(MAX_SHOWN_LINE_CHARS).collect();
        let lead = if start > 0 { "…" } else { "" };
        let tail = if start + MAX_SHOWN_LINE_CHARS < chars { "…" } else { "" };
        out.push_str(&format!("{lead}{window}{tail}{end}"));
        if let Some(l) = here {
            moved = Some(SpecLocation { line: l.line, column: (column - start + lead.chars().count() + 1) as u64 });
        }
    }
    (out, moved)
}

/// A spec that is not UTF-8: where the first bad byte is (line, column in
/// characters), with the text shown up to there.
fn not_utf8(path: &Path, e: std::string::FromUtf8Error) -> SpecError {
    let valid_up_to = e.utf8_error().valid_up_to();
    let bytes = e.into_bytes();
    let before = std::str::from_utf8(&bytes[..valid_up_to]).unwrap_or_default();
    let line = before.matches('\n').count() as u64 + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) as u64 + 1;
    SpecError::Parse {
        path: path.to_path_buf(),
        location: Some(SpecLocation { line, column }),
        message: format!(
            "not UTF-8 text: byte 0x{:02x} at offset {valid_up_to}; save the spec as UTF-8",
            bytes.get(valid_up_to).copied().unwrap_or_default()
        ),
        text: String::from_utf8_lossy(&bytes).into_owned(),
    }
}

/// The JSON Schema of each spec kind, for editors (`safer schema`).
pub fn json_schema(kind: SpecKind) -> serde_json::Value {
    let schema = match kind {
        SpecKind::Scenario => schemars::schema_for!(scenario::ScenarioSpec),
        SpecKind::Suite => schemars::schema_for!(suite::SuiteSpec),
        SpecKind::Planner => schemars::schema_for!(planner::PlannerSpec),
    };
    serde_json::to_value(schema).unwrap_or_default()
}

/// The kinds of spec file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpecKind {
    /// `specs/scenarios/*.yaml`.
    Scenario,
    /// `specs/suites/*.yaml`.
    Suite,
    /// `planners/*.yaml`.
    Planner,
}

impl SpecKind {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Scenario, Self::Suite, Self::Planner];
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parser_budgets_are_named_in_words_not_as_debug_text() {
        let m = plain_words("budget breached: Nodes { nodes: 250001 }");
        assert_eq!(
            m,
            "the spec goes past the parser's limit on values (it stopped at 250001); a spec this large is a \
             generated file or a YAML bomb, not a hand-written spec"
        );
        let m = plain_words("budget breached: Events { events: 1000001 }");
        assert!(m.contains("limit on parser events (it stopped at 1000001)") && !m.contains('{'), "{m}");
    }

    #[test]
    fn a_message_quoting_a_huge_value_is_cut() {
        let cut = cut_message(format!("invalid type: string \"{}\"", "x".repeat(20_000)));
        assert!(cut.chars().count() < 460 && cut.ends_with("(20023 characters in all)"), "{cut}");
        assert_eq!(cut_message("short".into()), "short");
    }

    fn parse_error(text: &str) -> SpecError {
        parse_yaml::<serde_json::Value>(text, Path::new("s.yaml")).unwrap_err()
    }

    #[test]
    fn duplicate_keys_and_second_documents_are_explained_in_plain_words() {
        let e = parse_error("name: a\nname: b\n");
        let m = e.to_string();
        assert_eq!(m, "s.yaml:2:1: key `name` appears twice in the same mapping (first at line 1); keep one");
        assert!(!m.contains("DuplicateKeyPolicy"), "{m}");
        let m = parse_error("name: a\n---\nname: b\n").to_string();
        assert!(m.contains("one YAML document") && !m.contains("from_str_multiple"), "{m}");
    }

    #[test]
    fn empty_files_and_negative_or_fractional_counts_are_explained_in_plain_words() {
        #[derive(Debug, serde::Deserialize)]
        struct Counts {
            #[allow(dead_code)]
            n: u32,
        }
        for text in ["n: -1\n", "n: 1e300\n", "n: 1.5\n"] {
            let e = parse_yaml::<Counts>(text, Path::new("s.yaml")).unwrap_err().to_string();
            assert_eq!(e, "s.yaml:1:4: expected a whole number from 0 to 4294967295 here", "{text}");
        }
        let e = parse_yaml::<Counts>("", Path::new("s.yaml")).unwrap_err().to_string();
        assert!(e.starts_with("s.yaml:1:1: the file is empty or ends early"), "{e}");
    }

    #[test]
    fn a_bare_file_name_resolves_against_the_current_folder() {
        let spec = parse_yaml::<serde_json::Value>("a: 1\n", Path::new("suite.yaml")).unwrap();
        assert_eq!(spec.dir(), Path::new("."));
    }

    #[test]
    fn numbers_out_of_range_or_nan_are_refused_at_their_value() {
        // The value checked is passed in; the text only places it.
        let spec = parse_yaml::<serde_json::Value>("x:\n  gap: 1\n", Path::new("s.yaml")).unwrap();
        let e = spec.check_number("x.gap", f64::NAN, NumberRange::closed(0.0, 1.0), "m").unwrap_err();
        assert_eq!(e.to_string(), "s.yaml:2:8: `gap` must be a number in [0, 1] m, got NaN");
        assert!(spec.check_number("x.gap", 0.0, NumberRange::above(0.0, 1.0), "m").is_err());
        assert!(spec.check_number("x.gap", 1.0, NumberRange::above(0.0, 1.0), "m").is_ok());
    }
}
