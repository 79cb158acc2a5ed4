//! The README and the user guide (`docs/`) stay true:
//!
//! - every fenced `sh` block of a page runs, in the page's order, in a scratch copy of the
//!   repository's data and models with `slipbayes` on the PATH (the binary these tests
//!   built); every `toml` block is a model file, or a part of one, that the model parser
//!   accepts; `python` blocks are run by `python/tests/test_docs.py`;
//! - a block preceded by `<!-- not run: REASON -->` is not run (the reason must be given);
//!   one preceded by `<!-- file: PATH -->` is also written to PATH in the scratch copy,
//!   for the blocks after it;
//! - the command-line reference `docs/cli.md` is what the parser prints (`slipbayes
//!   reference`);
//! - the model-file chapter's key tables list every key the parser knows, and no other;
//! - every repository path a page names exists, every `slipbayes` command and flag it names
//!   is in the reference, every model-file key or table it names is the parser's, and every
//!   link between pages reaches an existing page and heading.
#![cfg(all(feature = "report", not(feature = "mpi")))]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

use slipbayes::run_file::RunFile;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .canonicalize()
        .unwrap()
}

/// The pages users read: the README, the guide, and the reports' index.
fn pages() -> Vec<PathBuf> {
    let root = root();
    let mut pages = vec![root.join("README.md"), root.join("reports/README.md")];
    let mut guide: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    guide.sort();
    pages.extend(guide);
    pages
}

/// The guide's chapters whose blocks the tests below run, one test each.
const CHAPTERS: [&str; 17] = [
    "README.md",
    "docs/README.md",
    "docs/install.md",
    "docs/tutorial.md",
    "docs/import.md",
    "docs/model-files.md",
    "docs/scenes-and-pooling.md",
    "docs/reading-the-report.md",
    "docs/comparing-materials.md",
    "docs/comparing-laws.md",
    "docs/campaigns.md",
    "docs/watch.md",
    "docs/clusters.md",
    "docs/python.md",
    "docs/sampler.md",
    "docs/calibration.md",
    "docs/maintaining.md",
];

/// Pages that are not chapters of the guide: reference text whose blocks are checked for
/// paths, commands and keys but hold nothing to run (or are generated).
const NOT_CHAPTERS: [&str; 4] = [
    "reports/README.md",
    "docs/cli.md",
    "docs/model.md",
    "docs/mpi.md",
];

/// Commands the reference does not list: of the MPI build only (the reference is the default
/// build's), and the hidden command that prints the reference.
const UNLISTED_COMMANDS: [&str; 2] = ["mpi-latency", "reference"];

fn relative(page: &Path) -> String {
    page.strip_prefix(root())
        .unwrap_or(page)
        .display()
        .to_string()
}

fn read(page: &Path) -> String {
    std::fs::read_to_string(page).unwrap_or_else(|e| panic!("{}: {e}", page.display()))
}

/// A fenced code block of a page.
#[derive(Debug, Clone)]
struct Block {
    /// Line of the opening fence (1-based).
    line: usize,
    /// The fence's info string: `sh`, `toml`, `python`, `text`, …
    lang: String,
    text: String,
    /// `<!-- not run: REASON -->` before the fence.
    not_run: Option<String>,
    /// `<!-- file: PATH -->` before the fence.
    file: Option<String>,
}

fn blocks(text: &str) -> Vec<Block> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let trimmed = lines[i].trim_start();
        let indent = lines[i].len() - trimmed.len();
        if let Some(info) = trimmed.strip_prefix("```") {
            let mut body = Vec::new();
            let mut j = i + 1;
            while j < lines.len() && lines[j].trim() != "```" {
                body.push(lines[j].get(indent..).unwrap_or(lines[j].trim_start()));
                j += 1;
            }
            let before = (0..i)
                .rev()
                .map(|k| lines[k].trim())
                .find(|l| !l.is_empty());
            let marker = |name: &str| {
                before
                    .and_then(|l| l.strip_prefix("<!--"))
                    .and_then(|l| l.strip_suffix("-->"))
                    .and_then(|l| l.trim().strip_prefix(name))
                    .map(|r| r.trim().to_owned())
            };
            out.push(Block {
                line: i + 1,
                lang: info.trim().to_owned(),
                text: body.join("\n") + "\n",
                not_run: marker("not run:"),
                file: marker("file:"),
            });
            i = j + 1;
        } else {
            i += 1;
        }
    }
    out
}

/// The text of a page outside its fenced blocks.
fn prose(text: &str) -> String {
    let mut out = String::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            out.push('\n');
            continue;
        }
        if !fenced {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

/// Inline code spans of prose, with their lines.
fn code_spans(prose: &str) -> Vec<(usize, String)> {
    let mut spans = Vec::new();
    for (n, line) in prose.lines().enumerate() {
        let mut rest = line;
        while let Some(start) = rest.find('`') {
            let ticks = rest[start..].chars().take_while(|&c| c == '`').count();
            let after = &rest[start + ticks..];
            let fence = "`".repeat(ticks);
            let Some(end) = after.find(&fence) else { break };
            spans.push((n + 1, after[..end].trim().to_owned()));
            rest = &after[end + ticks..];
        }
    }
    spans
}

/// Links `[text](target)` of prose, with their lines.
fn links(prose: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in prose.lines().enumerate() {
        let mut rest = line;
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(end) = after.find(')') else { break };
            out.push((n + 1, after[..end].to_owned()));
            rest = &after[end..];
        }
    }
    out
}

/// GitHub's anchor of a heading: lower case, punctuation dropped, spaces as hyphens.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(text: &str) -> BTreeSet<String> {
    prose(text)
        .lines()
        .filter_map(|l| l.strip_prefix('#'))
        .map(|l| anchor(l.trim_start_matches('#')))
        .collect()
}

// ---------------------------------------------------------------------------------------
// The command-line reference.

fn slipbayes() -> Command {
    Command::new(env!("CARGO_BIN_EXE_slipbayes"))
}

#[test]
fn the_command_line_reference_is_what_the_parser_prints() {
    let out = slipbayes().arg("reference").output().unwrap();
    assert!(out.status.success());
    let printed = String::from_utf8(out.stdout).unwrap();
    let committed = read(&root().join("docs/cli.md"));
    assert!(
        printed == committed,
        "docs/cli.md is stale: regenerate it with `cargo run --release -- reference > docs/cli.md`"
    );
}

/// Each command of the reference with the flags its help lists (`""`: the top level).
fn reference_flags() -> BTreeMap<String, BTreeSet<String>> {
    let text = read(&root().join("docs/cli.md"));
    let mut flags: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut command = None;
    for line in text.lines() {
        if let Some(title) = line.strip_prefix("## slipbayes") {
            let name = title.trim().to_owned();
            flags.entry(name.clone()).or_default();
            command = Some(name);
            continue;
        }
        let Some(command) = &command else { continue };
        for word in line.split(|c: char| c.is_whitespace() || c == ',' || c == '[' || c == '=') {
            if let Some(flag) = word.strip_prefix("--") {
                let flag: String = flag
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
                    .collect();
                if !flag.is_empty() {
                    flags.get_mut(command).unwrap().insert(flag);
                }
            }
        }
    }
    flags
}

// ---------------------------------------------------------------------------------------
// The model file's keys, as the parser knows them.

/// A model file the parser accepts, to which the probes below add one key.
const BASE_MODEL: &str = r#"
[[material]]
name = "PTFE"

[[contact]]
name = "c1"
material = "PTFE"

[[run]]
name = "first"
contact = "c1"
data = "first.csv"
velocity_m_per_s = 1e-9
scene = "first"
"#;

/// The names the parser lists in its error for `text`: "expected one of `a`, `b`" (serde's
/// unknown field or variant) or "can be given for a, b" (the priors' names).
fn names_in_error(text: &str) -> Vec<String> {
    let err = RunFile::parse(text, Path::new("probe.toml"))
        .err()
        .unwrap_or_else(|| panic!("the parser accepted a probe with an unknown key:\n{text}"))
        .to_string();
    if let Some(list) = err.split("can be given for ").nth(1) {
        return list
            .split(',')
            .map(|n| n.trim().trim_end_matches('.').to_owned())
            .collect();
    }
    // serde: "expected `a`", "expected `a` or `b`", "expected one of `a`, `b`, `c`".
    let list = err
        .lines()
        .find_map(|l| l.split_once(", expected ").map(|(_, list)| list))
        .unwrap_or_else(|| panic!("no list of names in the parser's error: {err}"));
    list.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_owned)
        .collect()
}

/// Every table of a model file, by the name the guide gives it, with its keys, as the
/// parser lists them when it meets an unknown one. For `[levels]` and `[priors]` the keys
/// are the parameters; `[priors]` dists and their fields are `[priors] dist = "..."`.
fn schema() -> BTreeMap<String, BTreeSet<String>> {
    let set = |v: Vec<String>| v.into_iter().collect::<BTreeSet<_>>();
    let unknown = "zz_not_a_key";
    let mut tables = BTreeMap::new();
    tables.insert(
        "top level".to_owned(),
        set(names_in_error(&format!("{unknown} = 1\n{BASE_MODEL}"))),
    );
    tables.insert(
        "[[material]]".to_owned(),
        set(names_in_error(&BASE_MODEL.replace(
            "name = \"PTFE\"",
            &format!("name = \"PTFE\"\n{unknown} = 1"),
        ))),
    );
    tables.insert(
        "[[contact]]".to_owned(),
        set(names_in_error(&BASE_MODEL.replace(
            "material = \"PTFE\"",
            &format!("material = \"PTFE\"\n{unknown} = 1"),
        ))),
    );
    let run = |extra: &str| {
        BASE_MODEL.replace("scene = \"first\"", &format!("scene = \"first\"\n{extra}"))
    };
    tables.insert(
        "[[run]]".to_owned(),
        set(names_in_error(&run(&format!("{unknown} = 1")))),
    );
    tables.insert(
        "[[run]] columns".to_owned(),
        set(names_in_error(&run(&format!(
            "columns = {{ {unknown} = {{ name = \"t\" }} }}"
        )))),
    );
    tables.insert(
        "[[run]] columns.*".to_owned(),
        set(names_in_error(&run(&format!(
            "columns = {{ time = {{ name = \"t\", {unknown} = 1 }}, force = {{ name = \"f\" }} }}"
        )))),
    );
    for table in ["pooling", "sampler", "likelihood"] {
        tables.insert(
            format!("[{table}]"),
            set(names_in_error(&format!(
                "{BASE_MODEL}\n[{table}]\n{unknown} = 1\n"
            ))),
        );
    }
    tables.insert(
        "[levels]".to_owned(),
        set(names_in_error(&format!(
            "{BASE_MODEL}\n[levels]\n{unknown} = \"run\"\n"
        ))),
    );
    tables.insert(
        "[priors]".to_owned(),
        set(names_in_error(&format!(
            "{BASE_MODEL}\n[priors]\n{unknown} = {{ dist = \"uniform\", low = 1, high = 2 }}\n"
        ))),
    );
    let dists = names_in_error(&format!(
        "{BASE_MODEL}\n[priors]\nk = {{ dist = \"{unknown}\" }}\n"
    ));
    for dist in dists {
        let mut fields = set(names_in_error(&format!(
            "{BASE_MODEL}\n[priors]\nk = {{ dist = \"{dist}\", {unknown} = 1 }}\n"
        )));
        fields.insert("dist".to_owned());
        tables.insert(format!("[priors] dist = \"{dist}\""), fields);
    }
    tables
}

/// The key tables of the model-file chapter: under each heading `### <code>TABLE</code>`,
/// the first cell (in code) of every row of the table that follows.
fn documented_keys() -> BTreeMap<String, BTreeSet<String>> {
    let text = read(&root().join("docs/model-files.md"));
    let mut tables: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut current = None;
    for line in prose(&text).lines() {
        if let Some(heading) = line.strip_prefix("### ") {
            current = heading
                .split('`')
                .nth(1)
                .filter(|_| heading.starts_with('`'))
                .map(str::to_owned);
            if let Some(c) = &current {
                tables.entry(c.clone()).or_default();
            }
            continue;
        }
        if line.starts_with("## ") {
            current = None;
        }
        let (Some(table), Some(row)) = (&current, line.strip_prefix("| `")) else {
            continue;
        };
        let key = row.split('`').next().unwrap().to_owned();
        tables.get_mut(table).unwrap().insert(key);
    }
    tables
}

#[test]
fn the_model_file_chapter_lists_every_key_the_parser_knows() {
    let schema = schema();
    let documented = documented_keys();
    let mut problems = Vec::new();
    for (table, keys) in &schema {
        match documented.get(table) {
            None => problems.push(format!(
                "no section `### `{table}`` listing its keys {}",
                keys.iter()
                    .map(|k| format!("`{k}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
            Some(doc) => {
                for k in keys.difference(doc) {
                    problems.push(format!("{table}: `{k}` is not documented"));
                }
                for k in doc.difference(keys) {
                    problems.push(format!(
                        "{table}: `{k}` is documented but the parser has no such key"
                    ));
                }
            }
        }
    }
    for table in documented.keys().filter(|t| !schema.contains_key(*t)) {
        problems.push(format!("section `{table}` is not a table of a model file"));
    }
    assert!(
        problems.is_empty(),
        "docs/model-files.md and the model parser disagree:\n{}",
        problems.join("\n")
    );
}

/// Every key name a model file may hold, at any table.
fn all_keys(schema: &BTreeMap<String, BTreeSet<String>>) -> BTreeSet<String> {
    schema.values().flatten().cloned().collect()
}

// ---------------------------------------------------------------------------------------
// Model files in the pages.

/// Tables of `part` merged into `base`, recursively; arrays of tables replaced.
fn merge(base: &mut toml::Table, part: toml::Table) {
    for (k, v) in part {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(p)) => merge(b, p),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

#[test]
fn every_toml_block_is_a_model_the_parser_accepts() {
    let mut problems = Vec::new();
    let mut checked = 0;
    for page in pages() {
        for block in blocks(&read(&page))
            .into_iter()
            .filter(|b| b.lang == "toml")
        {
            let at = format!("{}:{}", relative(&page), block.line);
            let part: toml::Table = match toml::from_str(&block.text) {
                Ok(t) => t,
                Err(e) => {
                    problems.push(format!("{at}: not TOML: {e}"));
                    continue;
                }
            };
            // A part of a model file is checked within a whole one.
            let whole = if part.contains_key("run") {
                block.text.clone()
            } else {
                let mut base: toml::Table = toml::from_str(BASE_MODEL).unwrap();
                merge(&mut base, part);
                toml::to_string(&base).unwrap()
            };
            if let Err(e) = RunFile::parse(&whole, Path::new("guide.toml")) {
                problems.push(format!("{at}: {e}"));
            }
            checked += 1;
        }
    }
    assert!(checked >= 5, "only {checked} model files in the pages");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Paths, commands, keys and links named by the pages.

/// Whether a word names a file of the repository: it starts with one of its top-level
/// folders or files (user outputs such as `runs/demo/` do not).
fn repository_path(word: &str) -> Option<&str> {
    const TOP: [&str; 15] = [
        "data/",
        "docs/",
        "models/",
        "src/",
        "cli/",
        "reports/",
        "python/",
        "tests/",
        "benches/",
        "examples/",
        "fuzz/",
        ".ci/",
        "README.md",
        "Cargo.toml",
        "Cargo.lock",
    ];
    let word = word.trim_matches(|c: char| matches!(c, '(' | ')' | ',' | ';' | ':' | '"' | '\''));
    let word = word.split(['#', '*']).next().unwrap_or(word);
    TOP.iter()
        .any(|t| word.starts_with(t))
        .then_some(word)
        .filter(|w| !w.contains('{') && !w.contains("NNN") && !w.contains("DIR"))
}

/// The files a page's own blocks write, which need not exist in the repository: the targets
/// of `<!-- file: PATH -->` markers, of `> PATH` redirections and of `--out PATH`.
fn created_paths(text: &str) -> BTreeSet<String> {
    let mut created = BTreeSet::new();
    for b in blocks(text) {
        created.extend(b.file.clone());
        if b.lang != "sh" {
            continue;
        }
        let words: Vec<&str> = b.text.split_whitespace().collect();
        for pair in words.windows(2) {
            if matches!(pair[0], ">" | "--out" | "-o") {
                created.insert(pair[1].trim_matches(['"', '\'']).to_owned());
            }
        }
    }
    created
}

#[test]
fn what_the_pages_name_exists() {
    let root = root();
    let flags = reference_flags();
    let all_flags: BTreeSet<&String> = flags.values().flatten().collect();
    let schema = schema();
    let keys = all_keys(&schema);
    let tables: BTreeSet<String> = schema
        .keys()
        .filter_map(|t| {
            t.strip_prefix('[')
                .map(|r| r.split(']').find(|s| !s.is_empty()).unwrap_or(r))
        })
        .map(|t| t.trim_start_matches('[').to_owned())
        .collect();
    let mut problems = Vec::new();
    for page in pages() {
        let text = read(&page);
        let name = relative(&page);
        let physics = name == "docs/model.md" || name == "docs/mpi.md";
        let created = created_paths(&text);
        let prose = prose(&text);
        let mut words: Vec<(usize, String)> = code_spans(&prose);
        for b in blocks(&text).iter().filter(|b| b.lang == "sh") {
            for (n, line) in b.text.lines().enumerate() {
                let line = line.split(" #").next().unwrap_or(line);
                words.push((b.line + 1 + n, line.to_owned()));
            }
        }
        for (line, span) in &words {
            let at = format!("{name}:{line}");
            for word in span.split_whitespace() {
                if let Some(path) = repository_path(word) {
                    if !root.join(path).exists() && !created.contains(path) {
                        problems.push(format!("{at}: `{path}` does not exist"));
                    }
                }
            }
            if physics {
                continue;
            }
            // `slipbayes COMMAND ... --flag`: the command, and its flags, in the reference.
            let tokens: Vec<&str> = span.split_whitespace().collect();
            if let Some(at_cmd) = tokens.iter().position(|t| *t == "slipbayes") {
                let command = tokens.get(at_cmd + 1).copied().unwrap_or("");
                let known = flags
                    .get(command)
                    .or_else(|| command.starts_with('-').then(|| flags.get("").unwrap()));
                match known {
                    None if UNLISTED_COMMANDS.contains(&command) => {}
                    None if command.chars().all(|c| c.is_ascii_lowercase() || c == '-')
                        && !command.is_empty() =>
                    {
                        problems.push(format!("{at}: `slipbayes {command}` is not a command"))
                    }
                    None => {}
                    Some(known) => {
                        for t in &tokens[at_cmd + 1..] {
                            if let Some(flag) = t.strip_prefix("--") {
                                let flag = flag.split('=').next().unwrap();
                                if !flag.is_empty() && !known.contains(flag) && flag != "help" {
                                    problems.push(format!(
                                        "{at}: `slipbayes {command}` has no flag --{flag}"
                                    ));
                                }
                            }
                        }
                    }
                }
            } else if let Some(flag) = span.strip_prefix("--") {
                let flag: String = flag
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
                    .collect();
                if !span.contains(' ') && !all_flags.contains(&flag) && flag != "help" {
                    problems.push(format!("{at}: no command has the flag --{flag}"));
                }
            }
        }
        if physics {
            continue;
        }
        // Model-file keys in prose: `[table]`, `[[table]]` and `key = value`.
        for (line, span) in code_spans(&prose) {
            let at = format!("{name}:{line}");
            if let Some(table) = span
                .strip_prefix("[[")
                .and_then(|s| s.strip_suffix("]]"))
                .or_else(|| span.strip_prefix('[').and_then(|s| s.strip_suffix(']')))
            {
                if table.chars().all(|c| c.is_ascii_lowercase() || c == '_')
                    && !table.is_empty()
                    && !tables.contains(table)
                {
                    problems.push(format!("{at}: `{span}` is not a table of a model file"));
                }
            }
            // `key = value` with a TOML value: text in quotes, a number, a boolean, an array
            // or an inline table.
            let toml_value = |v: &str| {
                v.starts_with(['"', '[', '{', '-', '.'])
                    || v.starts_with(|c: char| c.is_ascii_digit())
                    || v.starts_with("true")
                    || v.starts_with("false")
            };
            if let Some((key, _)) = span.split_once(" = ").filter(|(_, v)| toml_value(v.trim())) {
                let key = key.trim();
                let last = key.rsplit('.').next().unwrap();
                let plain = key
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.');
                if plain && !key.is_empty() && !keys.contains(last) {
                    problems.push(format!("{at}: `{key}` is not a key of a model file"));
                }
            }
        }
        // Links between pages: the page, and the heading an anchor names.
        for (line, target) in links(&prose) {
            if target.starts_with("http") || target.starts_with("mailto:") {
                continue;
            }
            let at = format!("{name}:{line}");
            let (file, fragment) = target.split_once('#').unwrap_or((&target, ""));
            let linked = if file.is_empty() {
                page.clone()
            } else {
                page.parent().unwrap().join(file)
            };
            if !linked.exists() {
                problems.push(format!("{at}: link to `{target}`, which does not exist"));
                continue;
            }
            if !fragment.is_empty()
                && linked.extension().is_some_and(|x| x == "md")
                && !anchors(&read(&linked)).contains(fragment)
            {
                problems.push(format!("{at}: link to `{target}`: no such heading"));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The numbers a bold `**…**` holds in a line of text: `**130×**`, `**17.7 s**`, `**2.98**`.
fn bold_numbers(line: &str) -> Vec<String> {
    line.split("**")
        .skip(1)
        .step_by(2)
        .filter_map(|b| {
            let n: String = b
                .chars()
                .take_while(|c| c.is_ascii_digit() || *c == '.' || *c == ',')
                .filter(|c| *c != ',')
                .collect();
            (!n.is_empty()).then_some(n)
        })
        .collect()
}

/// Whether `text` holds a number that, rounded to the digits of `shown` (`130`, `17.7`),
/// is `shown`: a headline may round what its report states.
fn states(text: &str, shown: &str) -> bool {
    let Ok(value) = shown.parse::<f64>() else {
        return false;
    };
    let decimals = shown.split_once('.').map_or(0, |(_, d)| d.len());
    let scale = 10f64.powi(decimals as i32);
    let mut number = String::new();
    let mut found = false;
    for c in text.chars().chain(std::iter::once(' ')) {
        if c.is_ascii_digit() || (c == '.' && !number.is_empty()) {
            number.push(c);
        } else if c == ',' && !number.is_empty() {
            // Thousands separators: 27,009.
        } else if !number.is_empty() {
            let n = number.trim_end_matches('.');
            if let Ok(v) = n.parse::<f64>() {
                found |= ((v * scale).round() - value * scale).abs() < 0.5;
            }
            number.clear();
        }
    }
    found
}

/// The README's headline numbers are the reports' current ones: each bold number of a line
/// that links a report is stated by that report (rounded as the README shows it).
#[test]
fn the_readme_quotes_the_numbers_its_reports_state() {
    let root = root();
    let readme = read(&root.join("README.md"));
    let mut checked = 0;
    let mut problems = Vec::new();
    // A list item may run over several lines: join each item's lines.
    let mut items: Vec<String> = Vec::new();
    for line in prose(&readme).lines() {
        if line.starts_with("- ") {
            items.push(line.to_owned());
        } else if line.starts_with("  ") && !items.is_empty() {
            let last = items.last_mut().unwrap();
            last.push(' ');
            last.push_str(line.trim());
        } else {
            items.push(String::new());
        }
    }
    for item in items {
        let numbers = bold_numbers(&item);
        let reports: Vec<String> = links(&item)
            .into_iter()
            .map(|(_, t)| t)
            .filter(|t| t.starts_with("reports/") && t.ends_with(".md"))
            .collect();
        if numbers.is_empty() || reports.is_empty() {
            continue;
        }
        let text: String = reports.iter().map(|r| read(&root.join(r))).collect();
        for n in numbers {
            if states(&text, &n) {
                checked += 1;
            } else {
                problems.push(format!(
                    "README.md: {n} is not stated by {reports:?}: {item}"
                ));
            }
        }
    }
    assert!(checked >= 4, "only {checked} headline numbers checked");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn every_page_of_the_guide_is_listed_here() {
    let listed: BTreeSet<&str> = CHAPTERS.iter().chain(&NOT_CHAPTERS).copied().collect();
    for page in pages() {
        let name = relative(&page);
        assert!(
            listed.contains(name.as_str()),
            "{name}: add it to CHAPTERS (its blocks are run) or NOT_CHAPTERS in cli/tests/docs.rs"
        );
    }
    for page in NOT_CHAPTERS {
        let text = read(&root().join(page));
        if let Some(b) = blocks(&text)
            .iter()
            .find(|b| b.lang == "sh" && b.not_run.is_none())
        {
            panic!("{page}:{}: an `sh` block in a page whose blocks are not run: mark it `<!-- not run: REASON -->` or make the page a chapter", b.line);
        }
    }
}

#[test]
fn every_block_left_unrun_says_why() {
    for page in pages() {
        for b in blocks(&read(&page)) {
            if let Some(reason) = &b.not_run {
                assert!(
                    reason.len() >= 10,
                    "{}:{}: `not run:` needs a reason",
                    relative(&page),
                    b.line
                );
            }
            assert!(
                !b.lang.is_empty(),
                "{}:{}: a fenced block without a language (sh, toml, python, text)",
                relative(&page),
                b.line
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Running a chapter's commands.

/// A scratch copy of what the commands of a page read: `data/`, `models/`, the import
/// fixtures and the helper scripts, with `slipbayes` on the PATH.
struct Scratch {
    dir: tempfile::TempDir,
    path: String,
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

impl Scratch {
    fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let root = root();
        for tree in ["data", "models", "tests/fixtures/import", "benches/peer"] {
            copy_tree(&root.join(tree), &dir.path().join(tree));
        }
        let bin = dir.path().join(".bin");
        std::fs::create_dir_all(&bin).unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_slipbayes"), bin.join("slipbayes")).unwrap();
        let path = format!(
            "{}:{}",
            bin.display(),
            std::env::var("PATH").unwrap_or_default()
        );
        Self { dir, path }
    }
}

/// Runs the `sh` blocks of `page` one after the other in one scratch copy (a block may use
/// what an earlier one wrote), writing the blocks marked `file:` where they say.
fn run_chapter(page: &str) {
    let text = read(&root().join(page));
    let scratch = Scratch::new();
    let mut ran = 0;
    for block in blocks(&text) {
        if let Some(file) = &block.file {
            let to = scratch.dir.path().join(file);
            std::fs::create_dir_all(to.parent().unwrap()).unwrap();
            std::fs::write(&to, &block.text).unwrap();
        }
        if block.lang != "sh" || block.not_run.is_some() {
            continue;
        }
        let out = Command::new("bash")
            .args(["-e", "-o", "pipefail", "-c", &block.text])
            .current_dir(scratch.dir.path())
            .env("PATH", &scratch.path)
            .env("MPLBACKEND", "Agg")
            .stdin(std::process::Stdio::null())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{page}:{}: the block failed ({}):\n{}\n--- stdout\n{}\n--- stderr\n{}",
            block.line,
            out.status,
            block.text,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        ran += 1;
    }
    eprintln!("{page}: {ran} blocks ran");
}

macro_rules! chapter {
    ($name:ident, $page:literal) => {
        #[test]
        fn $name() {
            assert!(CHAPTERS.contains(&$page));
            run_chapter($page);
        }
    };
}

chapter!(readme_commands_run, "README.md");
chapter!(guide_contents_commands_run, "docs/README.md");
chapter!(install_commands_run, "docs/install.md");
chapter!(tutorial_commands_run, "docs/tutorial.md");
chapter!(import_commands_run, "docs/import.md");
chapter!(model_files_commands_run, "docs/model-files.md");
chapter!(
    scenes_and_pooling_commands_run,
    "docs/scenes-and-pooling.md"
);
chapter!(
    reading_the_report_commands_run,
    "docs/reading-the-report.md"
);
chapter!(
    comparing_materials_commands_run,
    "docs/comparing-materials.md"
);
chapter!(comparing_laws_commands_run, "docs/comparing-laws.md");
chapter!(campaigns_commands_run, "docs/campaigns.md");
chapter!(watch_commands_run, "docs/watch.md");
chapter!(clusters_commands_run, "docs/clusters.md");
chapter!(python_commands_run, "docs/python.md");
chapter!(sampler_commands_run, "docs/sampler.md");
chapter!(calibration_commands_run, "docs/calibration.md");
chapter!(maintaining_commands_run, "docs/maintaining.md");
