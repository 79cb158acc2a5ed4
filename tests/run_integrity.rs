//! Corruption of a run directory is refused, never read as valid: every byte flip of a
//! checkpoint or a `summary.json`, and flips at sampled bytes of a chain part, are refused by
//! every read-back path (resume, the chain readers of `report` and `load`, the summary
//! reader) with an error naming the file and what to do; runs written before checksums
//! (format 2 checkpoints, summaries without a checksum) are still read, as unverified.
#![cfg(feature = "parquet")]

mod hostile;

use std::fs;
use std::path::Path;

use hostile::{Scratch, TemplateState};
use slipbayes::fit::run_dir::SUMMARY_JSON;
use slipbayes::fit::{FitSummary, RunDir};
use slipbayes::storage::{
    verify_run, ChainReader, ChainSink, Integrity, ParquetSink, SinkOptions, StepView, StorageError,
};

/// Byte changes tried at every position: the lowest bit, the highest, all eight.
const MASKS: [u8; 3] = [0x01, 0x80, 0xff];

fn assert_names(message: &str, file: &str, advice: &str) {
    assert!(
        message.contains(file) && message.contains(advice),
        "an error that does not name {file} and say {advice:?}: {message}"
    );
}

/// Every read-back path of the chains, each asserted to refuse naming `file`.
fn assert_every_reader_refuses(run: &RunDir, file: &str, advice: &str) {
    let files = run.chain_files();
    let err = verify_run(&files).unwrap_err();
    assert_names(&err.to_string(), file, advice);
    let err = ChainReader::open_run(&files).unwrap_err();
    assert_names(&err.to_string(), file, advice);
    // The run directory's readers (what `report` and `load` call) keep the cause.
    for err in [
        run.chain_reader().unwrap_err(),
        run.read_chains().unwrap_err(),
    ] {
        let chain = std::iter::successors(Some(&err as &dyn std::error::Error), |e| e.source())
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(": ");
        assert_names(&chain, file, advice);
    }
    let err = ParquetSink::resume::<TemplateState>(&files).unwrap_err();
    assert_names(&err.to_string(), file, advice);
}

#[test]
fn an_intact_run_is_verified() {
    let tmp = tempfile::tempdir().unwrap();
    let scratch = Scratch::new(tmp.path());
    let run = scratch.fresh();
    fs::write(run.chain_files().checkpoint, &scratch.checkpoint).unwrap();
    assert_eq!(verify_run(&run.chain_files()).unwrap(), Integrity::Verified);
    let reader = run.chain_reader().unwrap();
    assert_eq!(reader.integrity(), &Integrity::Verified);
    assert_eq!(reader.steps(), 6);
    let (_, state) = ParquetSink::resume::<TemplateState>(&run.chain_files()).unwrap();
    assert_eq!(state.next_step, 6);
}

#[test]
fn every_byte_flip_and_truncation_of_a_checkpoint_is_refused_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let scratch = Scratch::new(tmp.path());
    let good = &scratch.checkpoint;
    let mut tried = 0;
    let mut corrupted = Vec::new();
    for i in 0..good.len() {
        for mask in MASKS {
            let mut bad = good.clone();
            bad[i] ^= mask;
            corrupted.push(bad);
        }
    }
    corrupted.extend((0..good.len()).map(|n| good[..n].to_vec()));
    for bad in corrupted {
        let run = scratch.fresh();
        fs::write(run.chain_files().checkpoint, &bad).unwrap();
        assert_every_reader_refuses(&run, "checkpoint.bin", "--overwrite");
        tried += 1;
    }
    assert_eq!(tried, good.len() * (MASKS.len() + 1));
}

#[test]
fn byte_flips_in_a_chain_part_are_refused_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let scratch = Scratch::new(tmp.path());
    let part = scratch.part().to_vec();
    // Every byte of a small part would be thousands of resumes; a seeded sample of positions
    // covers the header, the pages (numbers) and the footer.
    let mut z = 0x5eed_u64;
    let mut positions: Vec<usize> = (0..150)
        .map(|_| {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (z >> 33) as usize % part.len()
        })
        .collect();
    positions.extend([0, 3, part.len() / 2, part.len() - 5, part.len() - 1]);
    for i in positions {
        let mut bad = part.clone();
        bad[i] ^= MASKS[i % MASKS.len()];
        let run = scratch.fresh();
        let files = run.chain_files();
        fs::write(&files.checkpoint, &scratch.checkpoint).unwrap();
        fs::write(files.chains.join("part-000000.parquet"), &bad).unwrap();
        assert_every_reader_refuses(&run, "part-000000.parquet", "--overwrite");
    }
    // Cut short, too.
    let run = scratch.fresh();
    let files = run.chain_files();
    fs::write(&files.checkpoint, &scratch.checkpoint).unwrap();
    fs::write(
        files.chains.join("part-000000.parquet"),
        &part[..part.len() - 1],
    )
    .unwrap();
    assert_every_reader_refuses(&run, "part-000000.parquet", "--overwrite");
}

/// The committed demo's summary, written by [`RunDir::write_summary`] into a run whose
/// checkpoint is sealed.
fn sealed_summary_run(scratch: &Scratch) -> (RunDir, Vec<u8>, FitSummary) {
    let text =
        fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("reports/demo/summary.json"))
            .unwrap();
    let summary: FitSummary = serde_json::from_str(&text).unwrap();
    let run = scratch.fresh();
    fs::write(run.chain_files().checkpoint, &scratch.checkpoint).unwrap();
    run.write_summary(&summary).unwrap();
    let bytes = fs::read(run.file(SUMMARY_JSON)).unwrap();
    (run, bytes, summary)
}

#[test]
fn every_byte_flip_and_truncation_of_a_summary_is_refused_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let scratch = Scratch::new(tmp.path());
    let (run, good, summary) = sealed_summary_run(&scratch);
    let (read, integrity) = run.read_summary_verified().unwrap();
    assert_eq!(read, summary);
    assert_eq!(integrity, Integrity::Verified);
    // Still plain JSON for every other reader, with one more key.
    let value: serde_json::Value = serde_json::from_slice(&good).unwrap();
    assert!(value["checksum"].as_str().unwrap().starts_with("crc32:"));

    let path = run.file(SUMMARY_JSON);
    let mut refused = 0;
    for i in 0..good.len() {
        let mut bad = good.clone();
        bad[i] ^= MASKS[i % MASKS.len()];
        fs::write(&path, &bad).unwrap();
        let err = run.read_summary().unwrap_err().to_string();
        assert!(err.contains("summary.json"), "flip of byte {i}: {err}");
        refused += 1;
    }
    for n in (0..good.len()).step_by(7) {
        fs::write(&path, &good[..n]).unwrap();
        let err = run.read_summary().unwrap_err().to_string();
        assert!(err.contains("summary.json"), "cut at {n}: {err}");
    }
    assert_eq!(refused, good.len());
}

/// The template's checkpoint as the release before checksums wrote it: format 2, no seals of
/// parts, no trailer.
fn unsealed_checkpoint(sealed: &[u8]) -> Vec<u8> {
    let body = &sealed[..sealed.len() - 12];
    let mut reader = std::io::Cursor::new(body);
    let mut header: serde_json::Value = rmp_serde::from_read(&mut reader).unwrap();
    let state = &body[reader.position() as usize..];
    header["format"] = "slipbayes-chains/2".into();
    header
        .as_object_mut()
        .unwrap()
        .remove("part_seals")
        .unwrap();
    let mut bytes = rmp_serde::to_vec_named(&header).unwrap();
    bytes.extend_from_slice(state);
    bytes
}

#[test]
fn runs_of_earlier_releases_are_read_as_unverified() {
    let tmp = tempfile::tempdir().unwrap();
    let scratch = Scratch::new(tmp.path());
    let run = scratch.fresh();
    let files = run.chain_files();
    fs::write(&files.checkpoint, unsealed_checkpoint(&scratch.checkpoint)).unwrap();
    let unverified = |i: &Integrity| matches!(i, Integrity::Unverified { reason } if reason.contains("earlier release"));
    assert!(unverified(&verify_run(&files).unwrap()));
    let reader = run.chain_reader().unwrap();
    assert!(unverified(reader.integrity()));
    assert_eq!(reader.steps(), 6);
    // A summary without a checksum, as the earlier release wrote it.
    let (_, sealed, summary) = sealed_summary_run(&scratch);
    fs::write(&files.checkpoint, unsealed_checkpoint(&scratch.checkpoint)).unwrap();
    let text = String::from_utf8(sealed).unwrap();
    let cut = text.rfind(",\n  \"checksum\"").unwrap();
    fs::write(run.file(SUMMARY_JSON), format!("{}\n}}\n", &text[..cut])).unwrap();
    let (read, integrity) = run.read_summary_verified().unwrap();
    assert_eq!(read, summary);
    assert!(unverified(&integrity));
    // The same unsealed summary beside a sealed checkpoint lost its checksum: refused.
    fs::write(&files.checkpoint, &scratch.checkpoint).unwrap();
    let err = run.read_summary().unwrap_err().to_string();
    assert_names(&err, "summary.json", "--overwrite");
    // Resuming the old run seals its parts from then on.
    fs::write(&files.checkpoint, unsealed_checkpoint(&scratch.checkpoint)).unwrap();
    let (mut sink, state) = ParquetSink::resume::<TemplateState>(&files).unwrap();
    assert_eq!(state.next_step, 6);
    sink.checkpoint(&state).unwrap();
    sink.finish().unwrap();
    assert_eq!(verify_run(&files).unwrap(), Integrity::Verified);
}

/// A finished run whose burn-in was written into every part's footer (the parts rewritten
/// after they were sealed) is verified with the new seals.
#[test]
fn parts_rewritten_with_the_burn_in_are_sealed_again() {
    let tmp = tempfile::tempdir().unwrap();
    let run = RunDir::new(tmp.path());
    let files = run.chain_files();
    let options = SinkOptions {
        row_group_rows: 4,
        overwrite: false,
    };
    let mut sink = ParquetSink::create(&files, &["x".to_owned()], &[], options).unwrap();
    for step in 0..9u64 {
        let x = [step as f64, -(step as f64)];
        sink.record(&StepView {
            ensemble: 0,
            step,
            ndim: 1,
            positions: &x,
            log_density: &x,
            derived: &[],
        })
        .unwrap();
        if step % 3 == 2 {
            sink.checkpoint(&step).unwrap();
        }
    }
    sink.set_burn_in(3);
    sink.finish().unwrap();
    assert_eq!(verify_run(&files).unwrap(), Integrity::Verified);
    let metadata = run.chain_reader().unwrap().metadata().unwrap().unwrap();
    assert_eq!(metadata.burn_in, Some(3));
    let err = ParquetSink::resume::<u64>(&files).unwrap_err();
    assert!(matches!(err, StorageError::AlreadyFinished { .. }), "{err}");
}
