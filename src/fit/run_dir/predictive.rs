//! `predictive.csv`: per run and data time (subsampled), the observed force and the posterior
//! and posterior predictive bands.

use std::fmt::Write;
use std::path::Path;

use super::RunDirError;
use crate::model::Band;

/// The header of `predictive.csv`.
pub const PREDICTIVE_HEADER: &str = "run,time_s,observed_N,model_q025_N,model_median_N,model_q975_N,pred_q025_N,pred_q25_N,pred_q75_N,pred_q975_N";

/// The text of `predictive.csv`: one row per band point, numbers in their shortest exact form.
pub(crate) fn to_csv(bands: &[Band]) -> String {
    let mut csv = format!("{PREDICTIVE_HEADER}\n");
    for b in bands {
        for j in 0..b.time_s.len() {
            let _ = writeln!(
                csv,
                "{},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?}",
                b.run,
                b.time_s[j],
                b.observed_n[j],
                b.model_n[0][j],
                b.model_n[1][j],
                b.model_n[2][j],
                b.predictive_n[0][j],
                b.predictive_n[1][j],
                b.predictive_n[2][j],
                b.predictive_n[3][j]
            );
        }
    }
    csv
}

/// Parses `predictive.csv` (header `run,time_s,observed_N,model_q025_N,model_median_N,
/// model_q975_N,pred_q025_N,pred_q25_N,pred_q75_N,pred_q975_N`), grouping rows by run in
/// order of first appearance.
///
/// # Errors
/// [`RunDirError::Parse`] naming the line and column of a malformed field.
pub(super) fn parse(path: &Path, text: &str) -> Result<Vec<Band>, RunDirError> {
    let columns = PREDICTIVE_HEADER.split(',').count();
    let mut runs: Vec<Band> = Vec::new();
    let bad = |line: usize, message: String| RunDirError::Parse {
        path: path.to_path_buf(),
        message: format!("line {line}: {message}"),
    };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, header)) if header == PREDICTIVE_HEADER => {}
        _ => return Err(bad(1, format!("expected the header `{PREDICTIVE_HEADER}`"))),
    }
    for (index, line) in lines {
        let number = index + 1;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != columns {
            return Err(bad(
                number,
                format!("{} fields, expected {columns}", fields.len()),
            ));
        }
        let mut values = vec![0.0; columns - 1];
        for (k, field) in fields[1..].iter().enumerate() {
            values[k] = field.parse().map_err(|_| {
                bad(
                    number,
                    format!("column {}: {field:?} is not a number", k + 2),
                )
            })?;
        }
        let name = fields[0];
        if runs.last().is_none_or(|r| r.run != name) {
            runs.push(Band {
                run: name.to_owned(),
                time_s: Vec::new(),
                observed_n: Vec::new(),
                model_n: Default::default(),
                predictive_n: Default::default(),
            });
        }
        let run = runs.last_mut().expect("pushed above");
        run.time_s.push(values[0]);
        run.observed_n.push(values[1]);
        for q in 0..3 {
            run.model_n[q].push(values[2 + q]);
        }
        for q in 0..4 {
            run.predictive_n[q].push(values[5 + q]);
        }
    }
    Ok(runs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn predictive_csv_groups_runs_and_names_bad_lines() {
        let path = Path::new("predictive.csv");
        let text = format!(
            "{PREDICTIVE_HEADER}\na,0,1,1,1,1,0,0.5,1.5,2\na,1,5,1,1,1,0,0.5,1.5,2\nb,0,1,1,1,1,0,1,1,2\n"
        );
        let runs = parse(path, &text).unwrap();
        assert_eq!(runs.len(), 2);
        assert_eq!(runs[0].time_s.len(), 2);
        assert!((runs[1].predictive_n[3][0] - 2.0).abs() < 1e-12);
        // What is written reads back exactly.
        assert_eq!(parse(path, &to_csv(&runs)).unwrap(), runs);
        let err = parse(path, &format!("{PREDICTIVE_HEADER}\na,0,x,1,1,1,0,0,1,2\n")).unwrap_err();
        assert!(err.to_string().contains("line 2"), "{err}");
        assert!(err.to_string().contains("column 3"), "{err}");
    }
}
