#include "leap/cli.h"
#include "leap/files.h"

int main(int argc, char **argv)
{
    leap_signals_install();
    return leap_cli_main(argc, argv);
}
