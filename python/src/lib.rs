use pyo3::prelude::*;
#[pymodule]
fn _jeffcott(_m: &Bound<'_, PyModule>) -> PyResult<()> {
    Ok(())
}
