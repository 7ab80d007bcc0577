// ercube_pkg: the ercube model behind SystemVerilog DPI-C.
//
// One datapath sample of the model (the whole plain sample, or its
// bilinear or composite unit), evaluated bit for bit as the model computes
// it, for a scoreboard's expected words. The functions are the C ABI's
// (ffi/include/ercube.h, docs/verify.md): link the static library
// libercube_ffi.a (cargo build --release -p ercube-ffi) with -lpthread -ldl
// -lm, e.g. in Verilator:
//   $ verilator --cc --exe --build ercube_pkg.sv tb.sv unit.v sim_main.cpp \
//     -LDFLAGS "target/release/libercube_ffi.a -lpthread -ldl -lm"
//
// Words are raw two's-complement integers (the value is word * 2^-frac)
// held in a longint. Strings given as "" mean the default (the default
// configuration, the configuration's order, the whole sample). Every int
// result is a status, 0 for success; ercube_last_error() says what failed.
package ercube_pkg;

  // ERCUBE_ABI_VERSION of ercube.h this package is written against.
  localparam int unsigned ERCUBE_ABI_VERSION = 3;
  localparam int unsigned ERCUBE_INPUTS = 0;
  localparam int unsigned ERCUBE_OUTPUTS = 1;

  import "DPI-C" function int unsigned ercube_abi_version();
  import "DPI-C" function string ercube_last_error();

  // The unit `unit` ("sample", "bilinear", "composite") of the pipeline
  // configuration `toml` (TOML text), composited in `order` ("btf", "ftb").
  import "DPI-C" function int ercube_datapath_new(
    input string toml, input string order, input string unit, output chandle dp);
  import "DPI-C" function void ercube_datapath_free(input chandle dp);
  import "DPI-C" function int ercube_datapath_shape(
    input chandle dp, output int unsigned n_inputs, output int unsigned n_outputs,
    output int unsigned latency);
  // Port `index` of the inputs (side 0) or outputs (side 1).
  import "DPI-C" function int ercube_datapath_port(
    input chandle dp, input int unsigned side, input int unsigned index,
    output string name, output int unsigned bits, output int frac,
    output int unsigned is_signed);
  import "DPI-C" function int ercube_datapath_find(
    input chandle dp, input int unsigned side, input string name,
    output int unsigned index);
  // Tables (the whole sample's) from a transfer-function preset.
  import "DPI-C" function int ercube_datapath_fill_tables(input chandle dp, input string tf);
  // One table word: read it, or set it (as the module's host port writes it).
  import "DPI-C" function int ercube_datapath_table_get(
    input chandle dp, input string name, input int unsigned addr, output longint word);
  import "DPI-C" function int ercube_datapath_table_set(
    input chandle dp, input string name, input int unsigned addr, input longint word);
  // Hold input words, evaluate one sample, read output words.
  import "DPI-C" function int ercube_datapath_set(
    input chandle dp, input int unsigned index, input longint word);
  import "DPI-C" function int ercube_datapath_step(input chandle dp);
  import "DPI-C" function int ercube_datapath_get(
    input chandle dp, input int unsigned index, output longint word);

  // Stops the simulation with the model's message when `status` is a
  // failure.
  function automatic void ercube_check(int status, string what);
    if (status != 0)
      $fatal(1, "ercube: %s: status %0d: %s", what, status, ercube_last_error());
  endfunction

  // A datapath unit, checked against this package's ABI version.
  function automatic chandle ercube_open(string toml, string order, string unit);
    chandle dp;
    if (ercube_abi_version() != ERCUBE_ABI_VERSION)
      $fatal(1, "ercube: library ABI %0d, package %0d", ercube_abi_version(),
             ERCUBE_ABI_VERSION);
    ercube_check(ercube_datapath_new(toml, order, unit, dp), "ercube_datapath_new");
    return dp;
  endfunction

  // The index of the input (side 0) or output (side 1) named `name`.
  function automatic int unsigned ercube_index(chandle dp, int unsigned side, string name);
    int unsigned i;
    ercube_check(ercube_datapath_find(dp, side, name, i), {"ercube_datapath_find ", name});
    return i;
  endfunction

endpackage
