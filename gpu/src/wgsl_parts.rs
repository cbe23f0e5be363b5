//! WGSL programs written in parts. Both GPU stages keep their shaders this way: the simulation's
//! kernels get the declarations they share (and the force kernels their common code) put before
//! them; the tracer is one file per concept, each the twin of the CPU module of its name. WGSL
//! lets module-scope declarations come in any order, so joining is all a program needs.

/// The source of the WGSL program made of `parts`, in order, a newline between each two.
pub fn join_wgsl(parts: &[&str]) -> String {
    parts.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_are_joined_in_order_each_on_its_own_lines() {
        assert_eq!(join_wgsl(&["const A: u32 = 1u;", "", "fn f() {}\n"]), "const A: u32 = 1u;\n\nfn f() {}\n");
        assert_eq!(join_wgsl(&[]), "");
    }
}
