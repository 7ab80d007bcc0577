// Verilator main for the ercube scoreboard testbench (module tb, one clock
// input): toggles the clock until $finish and reports the clock rate.
#include <chrono>
#include <cstdio>
#include <memory>

#include "Vtb.h"
#include "verilated.h"

int main(int argc, char **argv) {
    auto ctx = std::make_unique<VerilatedContext>();
    ctx->commandArgs(argc, argv);
    auto top = std::make_unique<Vtb>(ctx.get());
    top->clk = 0;
    top->eval();
    auto t0 = std::chrono::steady_clock::now();
    unsigned long long edges = 0;
    while (!ctx->gotFinish()) {
        top->clk = !top->clk;
        top->eval();
        ctx->timeInc(1);
        edges++;
    }
    top->final();
    double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("ercube: %llu cycles in %.3f s (%.0f cycles/s)\n", edges / 2, s, edges / 2 / s);
    return 0;
}
