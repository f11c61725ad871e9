# bash completion for rosguard. Commands and options are read from rosguard's own --help when
# completing, so they follow the installed version. Installed as
# share/bash-completion/completions/rosguard.
_rosguard() {
  local cur prev words cword
  _init_completion || return
  local cmd="" i
  for ((i = 1; i < cword; i++)); do
    [[ ${words[i]} != -* ]] && { cmd=${words[i]}; break; }
  done
  if [[ -z $cmd ]]; then
    local cmds
    cmds=$("${words[0]}" --help 2>/dev/null | awk '/^Subcommands:/ {on=1; next} on && NF==0 {exit} on {print $1}')
    COMPREPLY=($(compgen -W "$cmds --help --version" -- "$cur"))
    return
  fi
  case $prev in
    --out | --from | -o) _filedir; return ;;
    --backend) COMPREPLY=($(compgen -W "sim hw" -- "$cur")); return ;;
    --confirm) COMPREPLY=($(compgen -W "hw" -- "$cur")); return ;;
    --objective) COMPREPLY=($(compgen -W "nrt-throughput" -- "$cur")); return ;;
    --rt-slowdown-max | --thresholds) return ;;
    --jobs | --shard | --array | --sbatch-arg | --name | --slice-instructions | --skip-instructions | --max-instructions) return ;;
  esac
  if [[ $cur == -* ]]; then
    local opts
    opts=$("${words[0]}" "$cmd" --help 2>/dev/null | grep -oE -- '--[a-z][a-z0-9-]*' | sort -u)
    COMPREPLY=($(compgen -W "$opts" -- "$cur"))
    return
  fi
  case $cmd in
    list) COMPREPLY=($(compgen -W "workloads platforms policies backends pmc-sources columns" -- "$cur")) ;;
    platform) COMPREPLY=($(compgen -W "probe model contention" -- "$cur")) ;;
    run | check | tune) _filedir json ;;
    status) _filedir -d ;;
    *) _filedir ;;
  esac
}
complete -F _rosguard rosguard
