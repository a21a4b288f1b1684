//! Refused request values, tagged with the option they came from. A job's messages name the
//! value and its valid range in the library's own words; the tag lets a front end (the command
//! line, a form) point at its own spelling of that option without parsing the sentence.

/// A request value a job refuses. `option` is the library's name for the input (a field of the
/// job's options, such as `"theta_i_deg"` or `"samples"`); the message is a whole sentence.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct BadInput {
    /// The library's name for the input that was refused.
    pub option: &'static str,
    /// What is wrong with it, naming the value and the valid range.
    pub message: String,
}

impl BadInput {
    /// A refusal of `option` with the sentence `message`.
    pub fn new(option: &'static str, message: impl Into<String>) -> BadInput {
        BadInput {
            option,
            message: message.into(),
        }
    }
}

/// The tag of the first [`BadInput`] anywhere in an error's chain.
pub fn option_of(e: &anyhow::Error) -> Option<&'static str> {
    e.chain()
        .find_map(|c| c.downcast_ref::<BadInput>())
        .map(|b| b.option)
}

/// Text without the UTF-8 byte-order mark some editors put at its start.
pub fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context;

    #[test]
    fn the_tag_is_found_under_added_context() {
        let e: anyhow::Result<()> = Err(BadInput::new("samples", "samples = 0: too few").into());
        let e = e.context("while planning").unwrap_err();
        assert_eq!(option_of(&e), Some("samples"));
        assert_eq!(format!("{e:#}"), "while planning: samples = 0: too few");
        assert_eq!(option_of(&anyhow::anyhow!("plain")), None);
    }
}
