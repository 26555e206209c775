// Hover trim.
