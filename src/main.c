#include "leap/cli.h"

int main(int argc, char **argv)
{
    return leap_cli_main(argc, argv);
}
