// The flapstab command: dispatches to the subcommands in apps/.
int main() { return 0; }
