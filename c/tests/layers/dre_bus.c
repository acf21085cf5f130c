/* A bus that calls up into the module above it: what tests/CMakeLists.txt's layers_cycle expects the layering
 * check (scripts/layers.py) to report as a call cycle. */
int dre_i_up(int x);
int dre_i_down(int x);

int dre_i_down(int x)
{
    return x > 0 ? dre_i_up(x - 1) : 0;
}
