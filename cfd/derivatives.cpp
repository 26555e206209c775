// Derivative extraction over any AeroModel (cycle-averaged, central differences).
