//! Readers of one validated option each, on top of the options database's `read_string`,
//! `read_real` and `read_int` (PETSc's way: each object reads its own options, a choice is
//! registered, listed in `-help` and checked in one call): [`OptionsBlock::string`],
//! [`OptionsBlock::real`] and [`OptionsBlock::int`], any value; [`OptionsBlock::choice`], one
//! of a list of named values; and [`OptionsBlock::real_in`] / [`OptionsBlock::int_in`], a
//! number within [`Bounds`]. Each registers its option (for `-help` and the check of the
//! options given) and refuses a bad value with a one-line [`SettingsError`] naming the option
//! and what it accepts. Each refuses its option given without a value (`-nndd_tol` last on
//! the line, or followed by another option), which PETSc reads as not given.

use super::{option_present, option_string, OptionsBlock, PetscError};

/// Bad input, naming the option and what it accepts (every layer's settings).
#[derive(Debug, thiserror::Error)]
pub enum SettingsError {
    #[error("{option} must be {accepted} (got {value})")]
    OutOfRange {
        option: String,
        accepted: &'static str,
        value: String,
    },
    #[error("{option}: unknown value '{value}' (accepted: {accepted})")]
    UnknownValue {
        option: String,
        value: String,
        accepted: String,
    },
    /// An option whose name depends on the mesh (`-nndd_bc_NAME_…`), a bad mesh file, or a
    /// value that conflicts with another option.
    #[error("{option}: {message}")]
    Named { option: String, message: String },
    #[error(transparent)]
    Petsc(#[from] PetscError),
}

impl SettingsError {
    /// `option must be accepted (got value)`.
    pub fn out_of_range(option: &str, accepted: &'static str, value: impl ToString) -> Self {
        SettingsError::OutOfRange {
            option: option.to_string(),
            accepted,
            value: value.to_string(),
        }
    }

    /// `option: message`.
    pub fn named(option: &str, message: impl Into<String>) -> Self {
        SettingsError::Named {
            option: option.to_string(),
            message: message.into(),
        }
    }
}

/// The values a number option accepts: the test, and how a message says it (`> 0`,
/// `in (-1, 0.5)`, `a positive integer (at most 65536)`).
#[derive(Clone, Copy, Debug)]
pub struct Bounds<T: 'static> {
    pub accepted: &'static str,
    pub holds: fn(T) -> bool,
}

impl Bounds<f64> {
    /// A finite number > 0.
    pub const POSITIVE: Bounds<f64> = Bounds {
        accepted: "> 0",
        holds: |x| x > 0.0 && x.is_finite(),
    };
    /// A fraction strictly between 0 and 1 (a relative tolerance: 1 or more is met at once).
    pub const FRACTION: Bounds<f64> = Bounds {
        accepted: "in (0, 1)",
        holds: |x| x > 0.0 && x < 1.0,
    };
    /// A finite number ≥ 0.
    pub const NON_NEGATIVE: Bounds<f64> = Bounds {
        accepted: ">= 0",
        holds: |x| x >= 0.0 && x.is_finite(),
    };
    /// Any finite number.
    pub const FINITE: Bounds<f64> = Bounds {
        accepted: "a finite number",
        holds: f64::is_finite,
    };
}

impl Bounds<i64> {
    /// A count: 1 … 65536 (mesh sizes, iteration limits).
    pub const POSITIVE_INT: Bounds<i64> = Bounds {
        accepted: "a positive integer (at most 65536)",
        holds: |v| (1..=1 << 16).contains(&v),
    };
    /// Any integer ≥ 0.
    pub const NON_NEGATIVE_INT: Bounds<i64> = Bounds {
        accepted: "an integer >= 0",
        holds: |v| v >= 0,
    };
}

/// Whether `option` was given without a value (PETSc reads a real or an integer option so
/// given as not given, a string option as given and empty).
fn without_value(option: &str) -> Result<bool, SettingsError> {
    Ok(option_present(option) && option_string(option)?.is_some_and(|v| v.is_empty()))
}

/// `option: needs a value (accepted: …)` where `option` was given without one.
fn needs_value(option: &str, accepted: &str) -> Result<(), SettingsError> {
    match without_value(option)? {
        true => Err(SettingsError::named(
            option,
            format!("needs a value ({accepted})"),
        )),
        false => Ok(()),
    }
}

/// What the user wrote for `option` (to quote in a message: PETSc's integers wrap around),
/// or `value` where it was not given.
fn as_given(option: &str, value: impl ToString) -> String {
    match option_string(option) {
        Ok(Some(text)) if !text.is_empty() => text,
        _ => value.to_string(),
    }
}

/// Whether the integer PETSc read, `value`, is not the number written (PETSc's 32-bit
/// integers wrap around: 4294967295 reads as -1); a text that is not a plain decimal
/// integer (hexadecimal, a keyword) is left to PETSc.
fn wrapped(option: &str, value: i64) -> bool {
    let written = option_string(option).ok().flatten();
    written
        .and_then(|t| t.trim().parse::<i128>().ok())
        .is_some_and(|n| n != i128::from(value))
}

impl OptionsBlock {
    /// A real option, registered with its help text and default, and whether it was given;
    /// refused given without a value.
    pub fn real(
        &mut self,
        option: &str,
        help: &str,
        default: f64,
    ) -> Result<(f64, bool), SettingsError> {
        let read = self.read_real(option, help, default)?;
        needs_value(option, "a number")?;
        Ok(read)
    }

    /// An integer option, as [`OptionsBlock::real`].
    pub fn int(
        &mut self,
        option: &str,
        help: &str,
        default: i64,
    ) -> Result<(i64, bool), SettingsError> {
        let read = self.read_int(option, help, default)?;
        needs_value(option, "an integer")?;
        Ok(read)
    }

    /// A string option, as [`OptionsBlock::real`].
    pub fn string(
        &mut self,
        option: &str,
        help: &str,
        default: &str,
    ) -> Result<(String, bool), SettingsError> {
        let read = self.read_string(option, help, default)?;
        needs_value(option, "-help describes it")?;
        Ok(read)
    }

    /// An option whose value is one of `values` (the first is the default): registered with
    /// its help text and the accepted values (`(choose one of) a b c`, as PETSc lists a
    /// choice), or refused naming them: `option: unknown value 'v' (accepted: a, b, c)`.
    pub fn choice<T: Copy>(
        &mut self,
        option: &str,
        help: &str,
        values: &[(&'static str, T)],
    ) -> Result<T, SettingsError> {
        let names: Vec<&str> = values.iter().map(|(n, _)| *n).collect();
        let help = format!("{help} (choose one of) {}", names.join(" "));
        let (given, _) = self.read_string(option, &help, values[0].0)?;
        needs_value(option, &format!("accepted: {}", names.join(", ")))?;
        values
            .iter()
            .find(|(name, _)| *name == given)
            .map(|&(_, v)| v)
            .ok_or_else(|| SettingsError::UnknownValue {
                option: option.to_string(),
                value: given,
                accepted: names.join(", "),
            })
    }

    /// A real option within `bounds` (registered with its help text and default), and whether
    /// it was given; else `option must be <accepted> (got v)`.
    pub fn real_in(
        &mut self,
        option: &str,
        help: &str,
        default: f64,
        bounds: Bounds<f64>,
    ) -> Result<(f64, bool), SettingsError> {
        let (v, given) = self.read_real(option, help, default)?;
        needs_value(option, bounds.accepted)?;
        if !(bounds.holds)(v) {
            let value = as_given(option, v);
            return Err(SettingsError::out_of_range(option, bounds.accepted, value));
        }
        Ok((v, given))
    }

    /// A count (an integer option ≥ 0) within `bounds`, as [`OptionsBlock::real_in`].
    pub fn int_in(
        &mut self,
        option: &str,
        help: &str,
        default: usize,
        bounds: Bounds<i64>,
    ) -> Result<(usize, bool), SettingsError> {
        let (v, given) = self.read_int(option, help, default as i64)?;
        needs_value(option, bounds.accepted)?;
        match usize::try_from(v) {
            Ok(count) if (bounds.holds)(v) && !wrapped(option, v) => Ok((count, given)),
            _ => {
                let value = as_given(option, v);
                Err(SettingsError::out_of_range(option, bounds.accepted, value))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_accept_what_their_words_say() {
        let positive = Bounds::POSITIVE.holds;
        assert!(positive(1e-300) && !positive(0.0) && !positive(f64::INFINITY));
        assert!(!positive(f64::NAN));
        assert!((Bounds::NON_NEGATIVE.holds)(0.0) && !(Bounds::NON_NEGATIVE.holds)(-1e-300));
        assert!((Bounds::FINITE.holds)(-1e300) && !(Bounds::FINITE.holds)(f64::NAN));
        let fraction = Bounds::FRACTION.holds;
        assert!(fraction(1e-300) && fraction(0.999) && !fraction(1.0) && !fraction(1e300));
        assert!(!fraction(0.0) && !fraction(f64::NAN));
        let count = Bounds::POSITIVE_INT.holds;
        assert!(count(1) && count(65536) && !count(0) && !count(65537));
        assert!((Bounds::NON_NEGATIVE_INT.holds)(0) && !(Bounds::NON_NEGATIVE_INT.holds)(-1));
    }

    #[test]
    fn messages_are_one_line_naming_the_option() {
        let e = SettingsError::out_of_range("-nndd_tol", "> 0", 0.0);
        assert_eq!(e.to_string(), "-nndd_tol must be > 0 (got 0)");
        let e = SettingsError::UnknownValue {
            option: "-nndd_stop".into(),
            value: "never".into(),
            accepted: "tol, balanced, none".into(),
        };
        assert_eq!(
            e.to_string(),
            "-nndd_stop: unknown value 'never' (accepted: tol, balanced, none)"
        );
        let e = SettingsError::named("-nndd_mesh", "cannot read it");
        assert_eq!(e.to_string(), "-nndd_mesh: cannot read it");
    }
}
