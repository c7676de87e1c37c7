//! The rendering method of a stimulus set: which algorithm turns a frame's scene into
//! pixels. Design files name it (`[method] kind = "tracer"`, the default), manifests record
//! it, and `render::Renderer` dispatches on it.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// A rendering method. The tracer is the reference every other method is compared with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The distribution (Monte Carlo) ray tracer: pixel area and shutter time sampled.
    #[default]
    Tracer,
    /// Accumulation buffer: instantaneous renders at several times in the shutter, averaged.
    Accum,
    /// McGuire et al. 2012 post-process motion blur (reconstruction filter).
    Mcguire,
    /// Guertin et al. 2014 post-process motion blur (filtering approach).
    Guertin,
    /// Gribel et al. 2010 analytic motion blur rasterizer (visibility over the shutter).
    Analytic,
}

impl Method {
    /// Every method, in the order reports list them.
    pub const ALL: [Method; 5] = [Method::Tracer, Method::Accum, Method::Mcguire, Method::Guertin, Method::Analytic];

    /// The name used in design files, manifests and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Tracer => "tracer",
            Method::Accum => "accum",
            Method::Mcguire => "mcguire",
            Method::Guertin => "guertin",
            Method::Analytic => "analytic",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Method::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
            format!("unknown rendering method `{s}`; expected one of {}", names.join(", "))
        })
    }
}

/// `[method]` of a design file: the set's rendering method.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MethodSpec {
    /// The method (default `tracer`).
    #[serde(default)]
    pub kind: Method,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_in_text_and_serde() {
        for m in Method::ALL {
            assert_eq!(m.name().parse::<Method>(), Ok(m));
            assert_eq!(serde_json::to_string(&m).unwrap(), format!("\"{}\"", m.name()));
            assert_eq!(serde_json::from_str::<Method>(&format!("\"{m}\"")).unwrap(), m);
        }
        let e = "raster".parse::<Method>().unwrap_err();
        assert_eq!(e, "unknown rendering method `raster`; expected one of tracer, accum, mcguire, guertin, analytic");
        assert_eq!(Method::default(), Method::Tracer);
        let spec: MethodSpec = toml::from_str("kind = \"guertin\"").unwrap();
        assert_eq!(spec.kind, Method::Guertin);
        assert!(toml::from_str::<MethodSpec>("kind = \"x\"").is_err());
        assert!(toml::from_str::<MethodSpec>("sort = \"tracer\"").is_err());
    }
}
