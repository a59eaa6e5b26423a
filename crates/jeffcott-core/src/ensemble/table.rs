//! Lane tables: an ensemble's lanes from a file, one row per lane, so a Monte Carlo over
//! uncertain parameters (k_c, mu, e drawn by the user) is one command.
//!
//! A table is a CSV file with a header, or a 2-D f64 `.npy` with its column names given
//! separately (a `lanes.npy` written by `jeffcott ensemble` needs none: its ten columns
//! are known). Columns: `omega`, any model parameter key ([`Params::names`]), start
//! coordinates by name (`x_r`, ... or `x_r0`, ... as in `lanes.npy`), and `param_set`
//! (an index into the `params.npy` written beside a `lanes.npy`; 0 = the base
//! parameters when there is none). Absent columns take the base values: the parameters of
//! `--config`/`--param`, the speed of `--omega`, the static equilibrium of the lane's
//! parameters with `--init` applied. Every value is checked; errors name the row (1 = the
//! first data row) and the column.

use super::LaneSpec;
use crate::error::{Error, Result};
use crate::model::{COORD_NAMES, Params, State, coord_index};
use std::path::Path;

/// A table of numbers with named columns.
#[derive(Clone, Debug, PartialEq)]
pub struct LaneTable {
    /// Column names.
    pub columns: Vec<String>,
    /// Rows, each as long as `columns`.
    pub rows: Vec<Vec<f64>>,
}

/// Most rows a lane table may have (one lane each).
pub const MAX_ROWS: usize = 1_000_000_000;

fn table_err(path: &Path, why: impl std::fmt::Display) -> Error {
    Error::invalid("lanes", path.display(), why.to_string())
}

impl LaneTable {
    /// Refuses a name that `option` (`init`, `param`) sets for every lane while the
    /// table has a column of that name: the column sets it lane by lane, so the option
    /// would be recorded and never used.
    pub fn refuse_set_by<'a>(
        &self,
        option: &str,
        names: impl IntoIterator<Item = &'a str>,
    ) -> Result<()> {
        for name in names {
            if self.columns.iter().any(|c| c == name) {
                return Err(Error::invalid(
                    option,
                    name,
                    format!(
                        "the lane table has a column {name}, which sets it in every lane; leave {name} out of `{option}` or drop the column"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Reads a CSV file with a header row (numbers only; `#` starts a comment line).
    pub fn read_csv(path: &Path) -> Result<LaneTable> {
        let mut r = csv::ReaderBuilder::new()
            .has_headers(true)
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .flexible(true)
            .from_path(path)
            .map_err(|e| table_err(path, format!("cannot be read as CSV: {e}")))?;
        let columns: Vec<String> = r
            .headers()
            .map_err(|e| table_err(path, format!("has no readable header row: {e}")))?
            .iter()
            .map(str::to_string)
            .collect();
        let mut rows = Vec::new();
        for (i, rec) in r.records().enumerate() {
            let row = i + 1;
            let rec = rec.map_err(|e| table_err(path, format!("row {row}: {e}")))?;
            if rec.len() != columns.len() {
                return Err(Error::invalid(
                    &format!("lanes row {row}"),
                    rec.len(),
                    format!("has {} fields; the header has {}", rec.len(), columns.len()),
                ));
            }
            let values = rec
                .iter()
                .zip(&columns)
                .map(|(s, c)| {
                    s.parse::<f64>().map_err(|_| {
                        Error::invalid(&format!("lanes row {row}, column {c}"), s, "not a number")
                    })
                })
                .collect::<Result<Vec<f64>>>()?;
            rows.push(values);
            if rows.len() > MAX_ROWS {
                return Err(table_err(path, format!("has more than {MAX_ROWS} rows")));
            }
        }
        Ok(LaneTable { columns, rows })
    }

    /// Reads a 2-D f64 `.npy` [rows, columns]; `columns` names them (`None`: the ten
    /// columns of a `lanes.npy`, [`super::lane_table_columns`]).
    pub fn read_npy(path: &Path, columns: Option<&[String]>) -> Result<LaneTable> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let f = npyz::NpyFile::new(&bytes[..])
            .map_err(|e| table_err(path, format!("is not an NPY file: {e}")))?;
        let shape = f.shape().to_vec();
        // `np.save` writes any transposed (Fortran-contiguous) array in column-major
        // order with `fortran_order: True`: its values run down the columns.
        let fortran = f.order() == npyz::Order::Fortran;
        let [nrows, ncols] = shape[..] else {
            return Err(table_err(
                path,
                format!("must be 2-D [lanes, columns]; its shape is {shape:?}"),
            ));
        };
        let values: Vec<f64> = f
            .into_vec()
            .map_err(|e| table_err(path, format!("must hold f64 values: {e}")))?;
        let columns: Vec<String> = match columns {
            Some(c) => c.to_vec(),
            None if ncols as usize == super::lane_table_columns().len() => {
                super::lane_table_columns()
            }
            None => {
                return Err(Error::invalid(
                    "columns",
                    "none",
                    format!(
                        "{} has {ncols} columns: name them with --columns a,b,... (only a lanes.npy of 10 columns needs none)",
                        path.display()
                    ),
                ));
            }
        };
        if columns.len() != ncols as usize {
            return Err(Error::invalid(
                "columns",
                columns.join(","),
                format!(
                    "names {} columns; {} has {ncols}",
                    columns.len(),
                    path.display()
                ),
            ));
        }
        if nrows as usize > MAX_ROWS {
            return Err(table_err(path, format!("has more than {MAX_ROWS} rows")));
        }
        let (nr, nc) = (nrows as usize, ncols as usize);
        let rows = if fortran {
            (0..nr)
                .map(|r| (0..nc).map(|c| values[c * nr + r]).collect())
                .collect()
        } else {
            values
                .chunks_exact(nc.max(1))
                .map(<[f64]>::to_vec)
                .collect()
        };
        Ok(LaneTable { columns, rows })
    }

    /// Reads a table by its extension: `.npy` (with `columns`), otherwise CSV.
    pub fn read(path: &Path, columns: Option<&[String]>) -> Result<LaneTable> {
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("npy"))
        {
            LaneTable::read_npy(path, columns)
        } else {
            if columns.is_some() {
                return Err(Error::invalid(
                    "columns",
                    path.display(),
                    "a CSV names its columns in its header; --columns is for .npy tables",
                ));
            }
            LaneTable::read_csv(path)
        }
    }
}

/// What a column sets.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Column {
    Omega,
    Param(&'static str),
    Coord(usize),
    ParamSet,
}

fn column(name: &str) -> Result<Column> {
    if name == "omega" {
        return Ok(Column::Omega);
    }
    if name == "param_set" {
        return Ok(Column::ParamSet);
    }
    if let Some(k) = Params::names().find(|k| *k == name) {
        return Ok(Column::Param(k));
    }
    let coord = name
        .strip_suffix('0')
        .and_then(coord_index)
        .or_else(|| coord_index(name));
    if let Some(i) = coord {
        return Ok(Column::Coord(i));
    }
    Err(Error::invalid(
        "lanes column",
        name,
        format!(
            "unknown column; valid names: omega, {}, a start coordinate ({} or with a trailing 0 as in lanes.npy), param_set",
            Params::names_list(),
            COORD_NAMES.join(", ")
        ),
    ))
}

/// The base values for columns a table leaves out.
pub struct TableDefaults<'a> {
    /// Parameters of every lane before its columns (`--config`, `--param`).
    pub params: &'a Params,
    /// Parameter sets `param_set` indexes (from a `params.npy`); empty: only 0, `params`.
    pub param_sets: &'a [Params],
    /// Speed of lanes without an `omega` column.
    pub omega: Option<f64>,
    /// Applied to each lane's static equilibrium before its coordinate columns (`--init`).
    pub init: &'a dyn Fn(&mut State) -> Result<()>,
    /// Start positions beyond this [m] are refused (the lane would be diverged at once).
    pub divergence_bound: f64,
}

/// The lanes of a table: one per row, each with its own parameter set where the row
/// changes parameters (identical sets are shared). Returns the parameter sets and lanes.
pub fn lanes_from_table(t: &LaneTable, d: &TableDefaults) -> Result<(Vec<Params>, Vec<LaneSpec>)> {
    let cols = table_columns(t, d)?;
    let mut sets: Vec<Params> = Vec::new();
    let mut index: std::collections::HashMap<Vec<u64>, u32> = Default::default();
    let mut lanes = Vec::with_capacity(t.rows.len());
    for (r, row) in t.rows.iter().enumerate() {
        let at = |c: usize| format!("lanes row {}, column {}", r + 1, t.columns[c]);
        let p = row_params(t, d, &cols, row, r + 1)?;
        let omega = match cols.iter().position(|c| *c == Column::Omega) {
            Some(c) => row[c],
            None => d.omega.unwrap_or(f64::NAN),
        };
        crate::model::validate_omega(omega).map_err(|_| {
            let name = match cols.iter().position(|c| *c == Column::Omega) {
                Some(c) => at(c),
                None => "omega".to_string(),
            };
            Error::invalid(
                &name,
                crate::model::short_number(omega),
                crate::model::OMEGA_RANGE,
            )
        })?;
        let x0 = row_start(d, &cols, row, &p, &at)?;
        let key: Vec<u64> = Params::names()
            .map(|k| p.get(k).unwrap_or(f64::NAN).to_bits())
            .collect();
        let set = *index.entry(key).or_insert_with(|| {
            sets.push(p.clone());
            (sets.len() - 1) as u32
        });
        lanes.push(LaneSpec {
            omega,
            x0,
            param_set: set,
        });
    }
    Ok((sets, lanes))
}

/// The table's columns, checked: each sets something of its own, the table has rows,
/// and every lane gets a speed (a column or the default).
fn table_columns(t: &LaneTable, d: &TableDefaults) -> Result<Vec<Column>> {
    let cols: Vec<Column> = t.columns.iter().map(|c| column(c)).collect::<Result<_>>()?;
    for (i, c) in t.columns.iter().enumerate() {
        if let Some(j) = (0..i).find(|&j| cols[j] == cols[i]) {
            return Err(Error::invalid(
                "lanes column",
                c,
                format!("sets the same thing as column {}", t.columns[j]),
            ));
        }
    }
    if t.rows.is_empty() {
        return Err(Error::invalid("lanes", 0, "the table has no rows"));
    }
    if d.omega.is_none() && !cols.contains(&Column::Omega) {
        return Err(Error::invalid(
            "omega",
            "none",
            "the lane table has no omega column: give --omega W for every lane",
        ));
    }
    Ok(cols)
}

/// The parameters of table row `row` (number `rown`, from 1): the base (or the indexed
/// set), then the row's parameter columns, validated; errors name the row and column.
fn row_params(
    t: &LaneTable,
    d: &TableDefaults,
    cols: &[Column],
    row: &[f64],
    rown: usize,
) -> Result<Params> {
    let at = |c: usize| format!("lanes row {rown}, column {}", t.columns[c]);
    let mut p = d.params.clone();
    if let Some(c) = cols.iter().position(|c| *c == Column::ParamSet) {
        let v = row[c];
        let ok = v >= 0.0 && v.fract() == 0.0 && (v as usize) < d.param_sets.len().max(1);
        if !ok {
            return Err(Error::invalid(
                &at(c),
                v,
                format!(
                    "must be a parameter set index in 0..{} ({})",
                    d.param_sets.len().max(1),
                    if d.param_sets.is_empty() {
                        "no params.npy beside the table: only 0, the base parameters"
                    } else {
                        "the rows of the params.npy beside the table"
                    }
                ),
            ));
        }
        if let Some(s) = d.param_sets.get(v as usize) {
            p = s.clone();
        }
    }
    for (c, col) in cols.iter().enumerate() {
        if let Column::Param(k) = col {
            p.set(k, row[c])?;
        }
    }
    p.validate().map_err(|e| match e {
        Error::InvalidParameter {
            name,
            value,
            reason,
        } => match t.columns.iter().position(|c| *c == name) {
            Some(c) => Error::invalid(&at(c), value, reason),
            None => Error::invalid(&format!("lanes row {rown}: {name}"), value, reason),
        },
        e => e,
    })?;
    Ok(p)
}

/// The start state of a row with parameters `p`: their static equilibrium, `d.init`,
/// then the row's coordinate columns (finite, positions within the divergence bound);
/// `at(c)` names column c of the row in errors.
fn row_start(
    d: &TableDefaults,
    cols: &[Column],
    row: &[f64],
    p: &Params,
    at: &dyn Fn(usize) -> String,
) -> Result<State> {
    let mut x0 = p.static_equilibrium();
    (d.init)(&mut x0)?;
    for (c, col) in cols.iter().enumerate() {
        if let Column::Coord(i) = col {
            let v = row[c];
            if !v.is_finite() {
                return Err(Error::invalid(
                    &at(c),
                    v,
                    "start coordinates must be finite",
                ));
            }
            let position = i % 2 == 0;
            if position && v.abs() > d.divergence_bound {
                return Err(Error::invalid(
                    &at(c),
                    v,
                    format!(
                        "start position beyond --divergence-bound {b} m; must be in -{b}..={b} m",
                        b = d.divergence_bound
                    ),
                ));
            }
            x0[*i] = v;
        }
    }
    Ok(x0)
}

/// The columns of `params.npy` for parameter sets `sets`: the article's parameters
/// ([`Params::FIELDS`]) where every set is the article's model, else every parameter
/// ([`Params::names`], a directional one at its value in effect).
pub fn params_columns(sets: &[Params]) -> Vec<&'static str> {
    if sets.iter().all(Params::is_article_model) {
        Params::FIELDS.to_vec()
    } else {
        Params::names().collect()
    }
}

/// Parameter sets as a table [sets, [`params_columns`]] (`params.npy`).
pub fn params_table(sets: &[Params]) -> Vec<f64> {
    let columns = params_columns(sets);
    sets.iter()
        .flat_map(|p| columns.iter().map(|k| p.get(k).unwrap_or(f64::NAN)))
        .collect()
}

/// Parameter sets from a `params.npy` [sets, columns] in [`params_columns`]' order: the
/// article's 14 columns, every parameter's 26, or the 24 before the contact laws'. A
/// directional parameter equal to its isotropic one stays unset.
pub fn read_params_table(path: &Path) -> Result<Vec<Params>> {
    let all: Vec<String> = Params::names().map(str::to_string).collect();
    let article = Params::FIELDS.len();
    let widths = [article, all.len() - 2, all.len()];
    let mut read = None;
    for w in widths {
        match LaneTable::read_npy(path, Some(&all[..w])) {
            Ok(t) => {
                read = Some((t, &all[..w]));
                break;
            }
            // Only a column count other than this width's tries the next one; an
            // unreadable file is its own error.
            Err(Error::InvalidParameter { name, .. }) if name == "columns" => continue,
            Err(e) => return Err(e),
        }
    }
    let (t, columns) = read.ok_or_else(|| {
        table_err(
            path,
            format!(
                "must have {article} columns ({}) or {} (with the machine variants' {})",
                Params::FIELDS.join(", "),
                all.len(),
                Params::VARIANT_FIELDS.join(", ")
            ),
        )
    })?;
    t.rows
        .iter()
        .enumerate()
        .map(|(r, row)| {
            let mut p = Params::default();
            for (k, v) in columns.iter().zip(row) {
                if p.get(k) != Some(*v) {
                    p.set(k, *v)?;
                }
            }
            p.validate().map_err(|e| {
                Error::invalid(
                    &format!("{} row {}", path.display(), r + 1),
                    "",
                    e.to_string(),
                )
            })?;
            Ok(p)
        })
        .collect()
}

/// A short checksum of the lanes and their parameters (FNV-1a over the bits), for a
/// run's specification: the same table resumes, another one is a different run.
pub fn lanes_checksum(sets: &[Params], lanes: &[LaneSpec]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |v: u64| {
        for b in v.to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for v in params_table(sets) {
        eat(v.to_bits());
    }
    for l in lanes {
        eat(l.omega.to_bits());
        eat(l.param_set as u64);
        for v in l.x0 {
            eat(v.to_bits());
        }
    }
    format!("{h:016x}")
}
