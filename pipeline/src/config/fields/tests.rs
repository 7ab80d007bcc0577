use super::PipelineConfig;

#[test]
fn default_validates() {
    let c = PipelineConfig::default();
    assert_eq!(c.validate().map_err(|e| e.to_string()), Ok(()));
    // The defaults the field documentation states.
    let shown: Vec<String> = c.formats().iter().map(|(_, f)| f.to_string()).collect();
    assert_eq!(
        shown,
        [
            "ufixed<12,12,TRN,SAT>",
            "fixed<28,12,RND,SAT>",
            "ufixed<25,1,RND,SAT>",
            "ufixed<12,0,TRN,SAT>",
            "ufixed<16,12,RND,SAT>",
            "ufixed<9,1,RND,SAT>",
            "ufixed<12,0,RND,SAT>",
            "ufixed<16,3,RND,SAT>",
            "ufixed<20,5,RND,SAT>",
            "ufixed<16,1,RND,SAT>",
            "ufixed<16,0,RND,SAT>",
            "ufixed<16,0,RND,SAT>",
            "ufixed<20,4,RND,SAT>",
            "fixed<20,14,RND,SAT>",
            "ufixed<16,1,RND,SAT>",
            "ufixed<20,14,TRN,SAT>",
            "fixed<16,2,RND,SAT>",
            "ufixed<13,1,TRN,SAT>",
            "ufixed<13,1,RND,SAT>",
            "ufixed<16,4,RND,SAT>",
            "ufixed<24,4,RND,SAT>",
            "ufixed<28,8,RND,SAT>",
            "fixed<32,16,RND,SAT>",
            "ufixed<13,1,RND,SAT>",
            "fixed<20,8,RND,SAT>",
            "ufixed<20,8,RND,SAT>",
            "ufixed<22,7,RND,SAT>",
            "ufixed<22,7,RND,SAT>",
        ]
    );
    assert_eq!((c.table_entries, c.exp_table_bits, c.pes), (4096, 10, 16));
    assert_eq!(c.table_shift(), 0);
    assert_eq!(c.position.int_bits(), 12);
    assert_eq!(c.max_position(), 2047);
    assert!(c.check_extent(1024).is_ok());
    assert!(c.check_extent(2047).is_ok());
    let e = c.check_extent(2048).unwrap_err();
    assert_eq!(e.field(), Some("position"));
    assert_eq!(
        e.to_string(),
        "position holds coordinates up to 2047, below the volume extent 2048"
    );
}
