use super::*;
use serde_json::json;

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn provenance() -> Provenance<'static> {
    Provenance {
        model: "lambert",
        parameters: json!({ "albedo": [0.5, 0.5, 0.5] }),
        white_furnace: false,
        backend: "cpu (f64 reference)",
    }
}

/// An RGB image of `w × h` cells whose values say where they are: cell k holds (k, 10k, 100k).
fn cells(w: usize, h: usize) -> Vec<f32> {
    (0..w * h)
        .flat_map(|k| [k as f32, 10.0 * k as f32, 100.0 * k as f32])
        .collect()
}

/// Writes every member of a set of two `.npy` files, an EXR and a C header at `exr`, holding
/// `values` (2 × 3 RGB cells), and commits it.
fn write_full_set(exr: &Path, values: &[f32]) -> Result<()> {
    let files = ArtifactSet::create(LUT_SET, exr, &["", "_avg"], &["h"])?;
    files.npy(0, &[2, 3, 3], values)?;
    files.npy(1, &[2, 3], &values[..6])?;
    let layer = ExrLayer {
        name: "E",
        width: 3,
        height: 2,
        channels: &["R", "G", "B"],
        values,
        attributes: &[("lobe.model", "lambert".to_string())],
    };
    files.exr(&[layer])?;
    files.text(0, "#define W 3\n")?;
    files.commit(&provenance(), json!({ "kind": "test set" }))
}

/// The members sit beside the EXR under its stem, in the order the set commits them, the sidecar
/// last; the sidecar holds the job's fields, the provenance fields and the set's record.
#[test]
fn an_artifact_set_writes_its_members_beside_the_exr() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let exr = dir.path().join("a.exr");
    let values = cells(3, 2);
    write_full_set(&exr, &values)?;
    assert_eq!(
        names(dir.path()),
        ["a.exr", "a.h", "a.json", "a.npy", "a_avg.npy"]
    );
    assert_eq!(
        npy::read(&dir.path().join("a.npy"))?,
        (vec![2, 3, 3], values.clone())
    );
    let avg = npy::read(&dir.path().join("a_avg.npy"))?;
    assert_eq!(avg, (vec![2, 3], values[..6].to_vec()));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("a.h"))?,
        "#define W 3\n"
    );
    let sidecar: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("a.json"))?)?;
    assert_eq!(
        sidecar,
        json!({
            "kind": "test set",
            "model": "lambert",
            "parameters": { "albedo": [0.5, 0.5, 0.5] },
            "white_furnace": false,
            "backend": "cpu (f64 reference)",
            "set": {
                "kind": "lut",
                "members": ["a.npy", "a_avg.npy", "a.exr", "a.h", "a.json"],
            },
        })
    );
    let image = exr::prelude::read_first_flat_layer_from_file(&exr)?;
    assert_eq!(image.layer_data.size, exr::prelude::Vec2(3, 2));
    let rgb = crate::table::exr_rgb(&image.layer_data, &exr)?;
    assert_eq!(rgb.concat(), values);
    Ok(())
}

/// An error part-way (here: the set dropped after its arrays and header, before its EXR and sidecar) leaves
/// the set written before as it was, and no temporary file.
#[test]
fn a_set_dropped_before_its_sidecar_changes_nothing() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let exr = dir.path().join("a.exr");
    write_full_set(&exr, &cells(3, 2))?;
    let before: Vec<Vec<u8>> = names(dir.path())
        .iter()
        .map(|n| std::fs::read(dir.path().join(n)))
        .collect::<std::io::Result<_>>()?;
    {
        let files = ArtifactSet::create(LUT_SET, &exr, &["", "_avg"], &["h"])?;
        files.npy(0, &[1, 3], &[7.0; 3])?;
        files.npy(1, &[1], &[7.0])?;
        files.text(0, "new\n")?;
    }
    let after: Vec<Vec<u8>> = names(dir.path())
        .iter()
        .map(|n| std::fs::read(dir.path().join(n)))
        .collect::<std::io::Result<_>>()?;
    assert_eq!(names(dir.path()).len(), 5, "{:?}", names(dir.path()));
    assert!(before == after, "a member changed");
    Ok(())
}

/// A member that cannot be written is refused when the set is created, naming it, before any
/// work; an array that does not fill its shape, and a sidecar field that the provenance also
/// gives, are refused, and nothing is written.
#[test]
fn a_member_in_the_way_a_short_array_or_a_field_given_twice_is_refused() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let exr = dir.path().join("a.exr");
    std::fs::create_dir(dir.path().join("a.h"))?;
    let err = ArtifactSet::create(ENGINE_LUT_SET, &exr, &[""], &["h"]).err();
    let text = err.map(|e| format!("{e:#}")).unwrap_or_default();
    assert!(
        text.contains("a.h: a folder of that name is in the way"),
        "{text}"
    );
    std::fs::remove_dir(dir.path().join("a.h"))?;

    let files = ArtifactSet::create(TABLE_SET, &exr, &[""], &[])?;
    let err = files.npy(0, &[2, 3], &[0.0; 5]).err();
    let text = err.map(|e| format!("{e:#}")).unwrap_or_default();
    assert!(
        text.contains("5 values do not fill the shape [2, 3]"),
        "{text}"
    );
    let err = files
        .finish(&provenance(), json!({ "model": "phong" }))
        .err();
    let text = err.map(|e| format!("{e:#}")).unwrap_or_default();
    assert!(
        text.contains("the sidecar field model is given twice"),
        "{text}"
    );
    assert!(names(dir.path()).is_empty(), "{:?}", names(dir.path()));
    Ok(())
}

/// A `.npy` streamed in chunks is the file written whole; the EXR made from it puts cell
/// `cell(x, y)` at pixel (x, y) (here a transpose: 2 × 3 cells, 3 × 2 pixels).
#[test]
fn a_streamed_npy_and_its_exr_mosaic_hold_the_cells() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let values = cells(3, 2);
    let whole = dir.path().join("whole.exr");
    let files = ArtifactSet::create(TABLE_SET, &whole, &[""], &[])?;
    files.npy(0, &[2, 3, 3], &values)?;
    let streamed = dir.path().join("streamed.exr");
    let stream_set = ArtifactSet::create(TABLE_SET, &streamed, &[""], &[])?;
    {
        let mut s = stream_set.npy_stream(0, &[2, 3, 3])?;
        for chunk in values.chunks(7) {
            s.write(chunk)?;
        }
        s.finish()?;
    }
    let transpose = |x: usize, y: usize| x * 3 + y;
    stream_set.exr_rgb_from_npy(0, "lobe", (2, 3), &transpose, &[])?;
    stream_set.commit(&provenance(), json!({}))?;
    files.exr(&[ExrLayer {
        name: "lobe",
        width: 3,
        height: 2,
        channels: &["R", "G", "B"],
        values: &values,
        attributes: &[],
    }])?;
    files.commit(&provenance(), json!({}))?;
    let read = |p: &str| std::fs::read(dir.path().join(p));
    assert_eq!(read("streamed.npy")?, read("whole.npy")?);
    let image = exr::prelude::read_first_flat_layer_from_file(&streamed)?;
    let rgb = crate::table::exr_rgb(&image.layer_data, &streamed)?;
    for y in 0..3 {
        for x in 0..2 {
            let k = transpose(x, y);
            assert_eq!(
                rgb[y * 2 + x],
                [values[3 * k], values[3 * k + 1], values[3 * k + 2]]
            );
        }
    }
    Ok(())
}
