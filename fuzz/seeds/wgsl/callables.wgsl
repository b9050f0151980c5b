@group(0) @binding(1) var<storage, read_write> out: array<u32>;

fn direct_callable__double() {
    rt_set_payload(0u, rt_get_payload(0u) * 2u);
}

fn continuation_callable__inc() {
    rt_set_payload(0u, rt_get_payload(0u) + 1u);
}

fn raygen__calls() {
    let id = rt_launch_index();
    var args: RtPayload;
    args[0] = id.x;
    rt_direct_call(0u, &args);
    rt_continuation_call(1u, &args);
    if args[0] > 100u {
        rt_throw_exception(3u);
    }
    out[id.x] = args[0] + rt_remaining_trace_depth();
}
