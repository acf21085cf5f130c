/* The module above the bus in the cycle of tests/layers/dre_bus.c. */
int dre_i_up(int x);
int dre_i_down(int x);

int dre_i_up(int x)
{
    return dre_i_down(x) + 1;
}
