//! Which instruction set the CPU backend's spring kernels use: the best this CPU has, or the one
//! forced by `--simd` or the `SHATTER_SIMD` environment variable, so that one machine can run and
//! bench every path. Every path gives the same bits (each kernel's tests compare them), so the
//! choice changes the speed only (docs/DECISIONS.md#simd-paths).

use std::fmt;
use std::sync::OnceLock;

/// The environment variable that forces a path for a process (`portable`, `avx2` or `avx512`).
const SIMD_ENV: &str = "SHATTER_SIMD";

/// The path forced by `--simd`, once per process.
static FORCED: OnceLock<SimdPath> = OnceLock::new();

/// A set of CPU kernels, from the most portable to the widest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum SimdPath {
    /// The lane code of both bond layouts, vectorised by the compiler for the build's target
    /// (AVX2 in the shipped x86-64 build, `.cargo/config.toml`; NEON on aarch64).
    Portable,
    /// The row layout's kernel in explicit AVX2 instructions; the lattice layout's lane code.
    Avx2,
    /// As `Avx2`, with the lattice layout's brick kernel in explicit AVX-512 instructions (two
    /// blocks to a 16-lane register).
    Avx512,
}

impl SimdPath {
    /// Every path, narrowest first.
    pub const ALL: [SimdPath; 3] = [SimdPath::Portable, SimdPath::Avx2, SimdPath::Avx512];

    /// The path's name, as `--simd` and `SHATTER_SIMD` take it.
    pub fn name(self) -> &'static str {
        match self {
            SimdPath::Portable => "portable",
            SimdPath::Avx2 => "avx2",
            SimdPath::Avx512 => "avx512",
        }
    }

    /// The path named `name`; the error lists the names.
    pub fn parse(name: &str) -> Result<SimdPath, String> {
        SimdPath::ALL.into_iter().find(|path| path.name() == name).ok_or_else(|| {
            let names: Vec<&str> = SimdPath::ALL.iter().map(|path| path.name()).collect();
            format!("unknown SIMD path {name:?}: expected one of {}", names.join(", "))
        })
    }

    /// Whether this CPU can run the path.
    pub fn supported(self) -> bool {
        match self {
            SimdPath::Portable => true,
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            #[cfg(not(target_arch = "x86_64"))]
            SimdPath::Avx2 | SimdPath::Avx512 => false,
        }
    }

    /// The paths this CPU can run, narrowest first.
    pub fn available() -> Vec<SimdPath> {
        SimdPath::ALL.into_iter().filter(|path| path.supported()).collect()
    }

    /// The widest path this CPU can run.
    pub fn best() -> SimdPath {
        SimdPath::available().pop().unwrap_or(SimdPath::Portable)
    }

    /// Forces `path` for the rest of the process (`--simd`): every CPU simulation made from then
    /// on runs it. Fails, naming the path, when this CPU lacks it or another path was forced.
    pub fn force(path: SimdPath) -> Result<(), String> {
        path.check("--simd")?;
        let forced = *FORCED.get_or_init(|| path);
        if forced == path { Ok(()) } else { Err(format!("--simd = {path}: the process already runs {forced}")) }
    }

    /// The path of this process's CPU simulations: the one forced by [`SimdPath::force`], else
    /// the one `SHATTER_SIMD` names, else the best. Fails, naming the variable and the value,
    /// when the name is unknown or this CPU lacks the path.
    pub fn for_process() -> Result<SimdPath, String> {
        if let Some(&path) = FORCED.get() {
            return Ok(path);
        }
        match std::env::var(SIMD_ENV) {
            Ok(name) => {
                let path = SimdPath::parse(&name).map_err(|e| format!("{SIMD_ENV}: {e}"))?;
                path.check(SIMD_ENV)?;
                Ok(path)
            }
            Err(_) => Ok(SimdPath::best()),
        }
    }

    /// Fails, naming `source` and the path, when this CPU lacks the path.
    fn check(self, source: &str) -> Result<(), String> {
        if self.supported() {
            return Ok(());
        }
        let available: Vec<&str> = SimdPath::available().iter().map(|path| path.name()).collect();
        Err(format!("{source} = {self}: this CPU cannot run the {self} kernels (it runs {})", available.join(", ")))
    }
}

impl fmt::Display for SimdPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_path_parses_from_its_name_and_a_bad_name_lists_them() {
        for path in SimdPath::ALL {
            assert_eq!(SimdPath::parse(path.name()), Ok(path));
        }
        let error = SimdPath::parse("sse9").expect_err("unknown");
        assert!(error.contains("\"sse9\"") && error.contains("portable, avx2, avx512"), "{error}");
    }

    #[test]
    fn the_portable_path_runs_everywhere_and_the_best_is_available() {
        assert!(SimdPath::Portable.supported());
        assert!(SimdPath::available().contains(&SimdPath::best()));
    }

    #[test]
    fn a_path_the_cpu_lacks_is_refused_by_name() {
        if let Some(missing) = SimdPath::ALL.into_iter().find(|path| !path.supported()) {
            let error = missing.check("--simd").expect_err("unsupported");
            assert!(error.starts_with(&format!("--simd = {missing}: this CPU cannot run")), "{error}");
        }
    }
}
