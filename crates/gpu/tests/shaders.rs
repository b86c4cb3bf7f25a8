//! Every WGSL shader of the GPU path parses and validates with naga on the host, whatever the
//! adapter (no device needed).

#[test]
fn every_shader_parses_with_naga() {
    // The shaders must at least parse and validate on the host, whatever the adapter.
    for (name, src) in [
        ("sampling", shscale_gpu::sampling::cast_source()),
        ("projection", shscale_gpu::sampling::project_source()),
        ("sh_eval", shscale_gpu::sampling::sh_test_source()),
        ("shading", shscale_gpu::shading::source()),
        ("cache", shscale_gpu::shading::cache_source()),
        ("sphere set", shscale_gpu::sphereset::source()),
        ("sphere set union", shscale_gpu::sphereset::union_source()),
        ("full field", shscale_gpu::field::source()),
        ("sub-volumes", shscale_gpu::parts::source()),
        ("pose and refit", shscale_gpu::pose::pose_source()),
    ] {
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {e:?}"));
    }
}
